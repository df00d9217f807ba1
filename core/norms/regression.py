"""The norm's covariates and the linear regression of a transformed figure on them.

A healthy person's expected figure depends on who they are and what they were measured
on: age, sex, the dominant hand, the arm tested and the robot (Kinarm's normative models
use the same, Kinarm Standard Tests Summary; Simmatis et al. 2020, J NeuroEng Rehabil
17:86, doi 10.1186/s12984-020-00713-2, Methods). The expected transformed figure is linear
in them:

    t̂ = β₀ + β_age·age_years + Σ_c Σ_{l ≠ reference(c)} β_{c=l}·[c = l]        (1)

each categorical covariate one-hot coded against its first level (the reference), and the
residual's spread σ is the residual standard deviation with n − p degrees of freedom.
A categorical covariate the controls had only one level of gets no column: the model knows
nothing of the other levels, and a person with one of them is refused, never guessed.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError

AGE = "age_years"
CATEGORICAL = ("sex", "handedness", "tested_side", "robot")
COVARIATES = (AGE, *CATEGORICAL)
ALLOWED_LEVELS = {
    "sex": ("female", "male"),
    "handedness": ("right", "left"),
    "tested_side": ("right", "left"),
}
"""The levels a categorical covariate may take; `robot` is any robot-kind string
(e.g. "simulator-realistic", or the hardware's)."""
INTERCEPT = "intercept"
AGE_LIMITS = (0.0, 130.0)


@dataclass(frozen=True)
class Covariates:
    """Who was measured, on what: the norm's covariates of one person at one session."""

    age_years: float
    sex: str
    handedness: str
    tested_side: str
    robot: str

    def __post_init__(self) -> None:
        age = self.age_years
        if isinstance(age, bool) or not isinstance(age, int | float) or not math.isfinite(
                age) or not AGE_LIMITS[0] <= age <= AGE_LIMITS[1]:
            raise ParameterError("age_years", age, f"a number from {AGE_LIMITS[0]:g} to "
                                 f"{AGE_LIMITS[1]:g}")
        for name in CATEGORICAL:
            check_level(name, getattr(self, name))

    def level(self, name: str) -> str:
        return getattr(self, name)


def check_level(name: str, value: object) -> str:
    """`value` if it is a level covariate `name` may take; ParameterError otherwise."""
    allowed = ALLOWED_LEVELS.get(name)
    if allowed is None:
        if not isinstance(value, str) or not value.strip() or len(value) > 100:
            raise ParameterError(name, value, "a robot-kind name (e.g. "
                                 "'simulator-realistic'), 1 to 100 characters")
    elif value not in allowed:
        raise ParameterError(name, value, " | ".join(allowed))
    return value


def column(name: str, level: str) -> str:
    """A one-hot column's name: `sex=male`."""
    return f"{name}={level}"


@dataclass(frozen=True)
class CovariateSpec:
    """What the controls covered: their age range and, per categorical covariate, the levels
    seen, the first one the reference."""

    age_range: tuple[float, float]
    levels: Mapping[str, tuple[str, ...]]

    def __post_init__(self) -> None:
        low, high = self.age_range
        if not (math.isfinite(low) and math.isfinite(high) and AGE_LIMITS[0] <= low <= high
                <= AGE_LIMITS[1]):
            raise ParameterError("age range", self.age_range, "two ages low ≤ high within "
                                 f"{AGE_LIMITS[0]:g}–{AGE_LIMITS[1]:g} years")
        if set(self.levels) != set(CATEGORICAL):
            raise ParameterError("covariate levels", sorted(self.levels),
                                 "exactly " + ", ".join(CATEGORICAL))
        for name, levels in self.levels.items():
            if not levels or len(set(levels)) != len(levels):
                raise ParameterError(f"levels of {name}", list(levels),
                                     "at least one level, none twice")
            for level in levels:
                check_level(name, level)

    @property
    def columns(self) -> tuple[str, ...]:
        """The design's columns in order: intercept, age, then each non-reference level."""
        one_hot = tuple(column(name, level) for name in CATEGORICAL
                        for level in self.levels[name][1:])
        return (INTERCEPT, AGE, *one_hot)

    def design(self, people: Sequence[Covariates]) -> np.ndarray:
        """The design matrix, one row per person, eq. (1); a level the controls did not
        have is refused (`unknown_levels`)."""
        rows = []
        for person in people:
            unknown = self.unknown_levels(person)
            if unknown:
                raise ParameterError(unknown[0][0], unknown[0][1],
                                     " | ".join(self.levels[unknown[0][0]]),
                                     "the norms hold no healthy people with it")
            row = [1.0, float(person.age_years)]
            for name in CATEGORICAL:
                row.extend(float(person.level(name) == level)
                           for level in self.levels[name][1:])
            rows.append(row)
        return np.asarray(rows, dtype=float).reshape(len(rows), len(self.columns))

    def unknown_levels(self, person: Covariates) -> list[tuple[str, str]]:
        return [(name, person.level(name)) for name in CATEGORICAL
                if person.level(name) not in self.levels[name]]

    def extrapolated(self, person: Covariates) -> bool:
        """True when the person's age lies outside the controls': the regression is
        extended beyond its data (the result says so; it is not refused)."""
        low, high = self.age_range
        return not low <= person.age_years <= high


def spec_of(people: Iterable[Covariates], references: Mapping[str, str] | None = None
            ) -> CovariateSpec:
    """The covariate spec of a set of controls: their age range and the levels they had,
    the reference first (ALLOWED_LEVELS' first, or the most common robot)."""
    people = list(people)
    if not people:
        raise ParameterError("controls", 0, "at least one person")
    ages = [p.age_years for p in people]
    levels = {}
    for name in CATEGORICAL:
        seen = [p.level(name) for p in people]
        order = ALLOWED_LEVELS.get(name) or tuple(sorted(set(seen), key=lambda v: (
            -seen.count(v), v)))
        chosen = [level for level in order if level in seen]
        reference = (references or {}).get(name)
        if reference in chosen:
            chosen.remove(reference)
            chosen.insert(0, reference)
        levels[name] = tuple(chosen)
    return CovariateSpec((float(min(ages)), float(max(ages))), levels)


@dataclass(frozen=True)
class Regression:
    """Eq. (1)'s coefficients by column, the residual SD σ and the number of controls n."""

    coefficients: Mapping[str, float]
    residual_sd: float
    n: int

    def predict(self, spec: CovariateSpec, people: Sequence[Covariates]) -> np.ndarray:
        beta = np.array([self.coefficients[c] for c in spec.columns], dtype=float)
        return spec.design(people) @ beta


def fit_regression(spec: CovariateSpec, design: np.ndarray, t) -> Regression:
    """Least squares of the transformed figure `t` on the design (rows per control);
    σ² = RSS/(n − p). Refused when the controls cannot determine the columns (fewer
    controls than columns plus two, or columns that are not independent, e.g. every
    left-handed control tested on the left)."""
    t = np.asarray(t, dtype=float).reshape(-1)
    n, p = design.shape
    if n < p + 2:
        raise ParameterError("controls", n, f"at least {p + 2} for {p} regression columns "
                             f"({', '.join(spec.columns)})")
    if np.linalg.matrix_rank(design) < p:
        raise ParameterError("controls' covariates", "not independent",
                             "controls whose covariates vary independently",
                             "e.g. every left-handed control tested on the left arm: "
                             "add controls, or leave one covariate's levels out")
    beta, *_ = np.linalg.lstsq(design, t, rcond=None)
    rss = float(np.sum((t - design @ beta) ** 2))
    sd = math.sqrt(rss / (n - p))
    if not sd > 0.0:
        raise ParameterError("residual SD", sd, "more than 0",
                             "the controls' figure is fitted exactly: no spread to norm")
    return Regression(dict(zip(spec.columns, map(float, beta), strict=True)), sd, n)
