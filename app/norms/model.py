"""A normative model in memory, and what it says of a patient: Z-scores, task scores, MDC95.

Every result carries the model's `source` and `simulated` flag: a report that prints a
Z-score prints where its norms came from (`NormativeModel.label`), and a simulated model
says "simulated — for demonstration and tests only" wherever it is used. The formulas are
core.norms'; docs/norms.md documents them and the file (app.norms.modelfile).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field

import numpy as np

from app.errors import AppError
from core.assessment.performed import not_performed
from core.errors import ParameterError
from core.norms import reliability, scores
from core.norms.regression import Covariates, CovariateSpec, Regression
from core.norms.transforms import Transform

SIMULATED_LABEL = "simulated — for demonstration and tests only"


class NormsError(AppError):
    """The norms cannot answer: a figure or task they do not hold, a person outside
    them, a value outside a transform's domain, no MDC95 for a change."""


Z_SHOWN = 10.0
"""Reports print a Z-score beyond ±Z_SHOWN as "< −10" / "> +10". That far out the transform
fitted on the controls is extrapolating (a Box-Cox of a speed of 0 with λ < 0 is minus
infinity: the passive patient's circle speed scored −6.7·10¹⁰), so the digits say nothing
but "far outside every control"; the number itself stays in `rehab norms score --json`."""


def z_text(z: float) -> str:
    """A Z-score as reports print it: signed, two decimals, or beyond ±Z_SHOWN as a bound."""
    if z < -Z_SHOWN:
        return f"< −{Z_SHOWN:g}"
    if z > Z_SHOWN:
        return f"> +{Z_SHOWN:g}"
    return f"{z:+.2f}"


def score_text(score: float) -> str:
    """A task score as reports print it: two decimals, or beyond Z_SHOWN as "> 10". A task
    score is a Z-Task Score mapped one-sided (about the same number that far out), so the
    same bound holds: 24 controls' range norms (λ = −5) gave the passive patient's area
    13184793.06, the extrapolated transform's digits; the number stays in --json."""
    return f"> {Z_SHOWN:g}" if score > Z_SHOWN else f"{score:.2f}"


WORST = "(worse than any task score)"
NO_RELIABILITY = "no reliability (ICC ≤ 0): SEM = SD"
"""What a table (`rehab norms mdc`, `rehab norms show`) marks beside an MDC95 whose ICC is
≤ 0 (docs/norms.md, Minimal detectable change), with NO_RELIABILITY_SAID once below it."""
NO_RELIABILITY_SAID = (f"{NO_RELIABILITY}, so its MDC95 is the whole spread of the retest's "
                       "measurements, not an error around a lasting trait")
"""What it means, said once under a table and beside Progress's real changes."""


class TaskNotPerformed(NormsError):
    """The patient did not perform the task (core.assessment.performed): no task score,
    and a result worse than any (reports say so, ranked last)."""

    def __init__(self, task: str, reason: str) -> None:
        super().__init__(f"{task} not performed: {reason} {WORST}")
        self.task = task
        self.reason = reason

    @property
    def line(self) -> str:
        """What a report prints in the task score's place."""
        return f"Task not performed: {self.reason} {WORST}"


@dataclass(frozen=True)
class FigureNorm:
    """One figure's norm: its transform, the regression on the covariates, the side that
    is worse, and its MDC95 in the figure's own units (None when the file has none)."""

    transform: Transform
    regression: Regression
    worse: str
    mdc95: float | None = None
    icc: float | None = None
    """The test-retest ICC the MDC95 came from (None when the file has none)."""


@dataclass(frozen=True)
class TaskNorm:
    """One task's score: the figures it combines, the transform of their distance, the
    controls' mean and SD of the transformed distance, n, and the score's MDC95."""

    figures: tuple[str, ...]
    transform: Transform
    mean: float
    sd: float
    n: int
    mdc95: float | None = None
    icc: float | None = None


EXTRAPOLATED = "(age beyond the controls')"
"""What a Z-score extrapolated to an age beyond the controls' says beside it, wherever it is
printed (`rehab norms score`, `rehab assess show`, the assessment page)."""


@dataclass(frozen=True)
class FigureZ:
    """A figure's Z-score against the norms (eq. 2 of docs/norms.md): positive is a figure
    higher than healthy people like the patient; `worse_z` positive is worse."""

    figure: str
    value: float
    z: float
    worse: str
    extrapolated: bool
    source: str
    simulated: bool

    @property
    def worse_z(self) -> float:
        return scores.worse_signed(self.z, self.worse)


@dataclass(frozen=True)
class TaskScore:
    """A task's score (docs/norms.md, eq. 4): 0 best, the controls half-normal; with the
    Z-Task Score, the distance and the figures' Z-scores it came from."""

    task: str
    score: float
    z_task: float
    distance: float
    figures: Mapping[str, FigureZ]
    extrapolated: bool
    source: str
    simulated: bool


@dataclass(frozen=True)
class Change:
    """Whether a figure or task score changed beyond its MDC95."""

    key: str
    before: float
    after: float
    mdc95: float
    real: bool


@dataclass(frozen=True)
class NormativeModel:
    """A loaded, verified normative model (app.norms.modelfile.load_norms)."""

    source: str
    simulated: bool
    covariates: CovariateSpec
    figures: Mapping[str, FigureNorm]
    tasks: Mapping[str, TaskNorm]
    content_sha256: str = ""
    calibration: Mapping = field(default_factory=dict)
    path: object = None
    notes: str = ""
    """The file's notes; a fit writes what it left out there, one `key: why` a line."""

    def left_out(self, key: str) -> str:
        """Why the fit left out a figure or a task (`task:<id>`), from the notes, or ""."""
        for line in self.notes.splitlines():
            if line.startswith(f"{key}: "):
                return line[len(key) + 2:]
        return ""

    @property
    def label(self) -> str:
        """What a report prints under anything it scored with these norms."""
        text = f"Norms: {self.source}"
        return f"{text} ({SIMULATED_LABEL})" if self.simulated else text

    def _figure(self, figure: str) -> FigureNorm:
        try:
            return self.figures[figure]
        except KeyError:
            why = self.left_out(figure)
            if why:
                raise NormsError(f"the norms ({self.source}) hold no figure {figure!r}: "
                                 f"{why}") from None
            raise NormsError(f"the norms ({self.source}) hold no figure {figure!r}; they "
                             f"hold {', '.join(sorted(self.figures)) or 'none'}") from None

    def check_person(self, person: Covariates) -> None:
        """NormsError when the controls had no one with one of the person's categorical
        levels (another robot, a sex or hand the fit left out): no figure can be scored, so
        a report or command says it once rather than once per figure."""
        unknown = self.covariates.unknown_levels(person)
        if unknown:
            name, level = unknown[0]
            raise NormsError(f"the norms ({self.source}) hold no healthy people with "
                             f"{name} {level!r} (they have "
                             f"{', '.join(self.covariates.levels[name])}): no Z-score is "
                             "given; use norms that include them")

    def z(self, figure: str, value: float, person: Covariates) -> FigureZ:
        """The figure's Z-score for this person (eq. 2)."""
        norm = self._figure(figure)
        self.check_person(person)
        if isinstance(value, bool) or not isinstance(value, int | float | np.number) or (
                not math.isfinite(value)):
            raise NormsError(f"{figure} = {value!r} is not a finite number: no Z-score")
        if not norm.transform.in_domain(value):
            # 0.0 − shift: a shift of 0 printed "more than -0"
            raise NormsError(f"{figure} = {value:g} is outside the norms' Box-Cox domain "
                             f"(more than {0.0 - norm.transform.shift:g}): no Z-score; the "
                             "norms need a larger shift or a Yeo-Johnson transform")
        t_value = float(norm.transform.apply(value))
        expected = float(norm.regression.predict(self.covariates, [person])[0])
        z = scores.z_score(t_value, expected, norm.regression.residual_sd)
        if not math.isfinite(z):
            raise NormsError(f"{figure} = {value:g} is beyond what the norms' transform can "
                             "hold (its Z-score overflows): check the value")
        return FigureZ(figure, float(value), z, norm.worse,
                       self.covariates.extrapolated(person), self.source, self.simulated)

    def z_scores(self, metrics: Mapping[str, float], person: Covariates
                 ) -> dict[str, FigureZ]:
        """The Z-score of every figure in `metrics` the norms hold; others, and figures
        the trial left undefined (None or NaN: a reach with no movement has no SPARC), are
        left out."""
        return {key: self.z(key, value, person) for key, value in metrics.items()
                if key in self.figures and _defined(value)}

    def task_score(self, task: str, metrics: Mapping[str, float], person: Covariates
                   ) -> TaskScore:
        """The task's score from its figures' values (docs/norms.md, eqs. 3-4)."""
        try:
            norm = self.tasks[task]
        except KeyError:
            why = self.left_out(f"task:{task}")
            if why:
                raise NormsError(f"the norms ({self.source}) hold no task score for {task!r}: "
                                 f"{why}") from None
            raise NormsError(f"the norms ({self.source}) hold no task score for {task!r}; "
                             f"they hold {', '.join(sorted(self.tasks)) or 'none'}") from None
        missing = [f for f in norm.figures if not _defined(metrics.get(f))]
        reason = not_performed(task, metrics)
        if reason:  # before `missing`: a task not done is the worst result, not a gap
            raise TaskNotPerformed(task, reason)
        if missing:
            raise NormsError(f"the {task} task score needs {', '.join(missing)}, which the "
                             "trial does not have (or left undefined): no task score")
        figures = {f: self.z(f, metrics[f], person) for f in norm.figures}
        try:
            distance = scores.task_distance({f: z.z for f, z in figures.items()},
                                            {f: z.worse for f, z in figures.items()},
                                            norm.figures)
        except ParameterError as exc:
            raise NormsError(f"the {task} task score: {exc}") from None
        if not norm.transform.in_domain(distance):
            raise NormsError(f"the {task} task's distance {distance:g} is outside the norms' "
                             "transform of it: no task score")
        z_task = scores.task_z(float(norm.transform.apply(distance)), norm.mean, norm.sd)
        return TaskScore(task, scores.task_score(z_task), z_task, distance, figures,
                         any(z.extrapolated for z in figures.values()), self.source,
                         self.simulated)

    def _norm(self, key: str) -> FigureNorm | TaskNorm:
        if key.startswith("task:"):
            task = self.tasks.get(key[5:])
            if task is None:
                raise NormsError(f"the norms ({self.source}) hold no task {key[5:]!r}")
            return task
        return self._figure(key)

    def mdc95(self, key: str) -> float | None:
        """The MDC95 of a figure (its units) or a task score (`task:<id>`), or None."""
        return self._norm(key).mdc95

    def reliability_note(self, key: str) -> str:
        """NO_RELIABILITY_SAID when the figure's (or `task:<id>`'s) test-retest ICC is ≤ 0,
        else "": its MDC95 is then 2.77 times the measurements' whole SD, not a measurement
        error under a lasting trait, and whoever reads it must be told."""
        icc = self._norm(key).icc
        return NO_RELIABILITY_SAID if icc is not None and icc <= 0.0 else ""

    def is_real_change(self, key: str, before: float, after: float) -> Change:
        """Whether a figure (or `task:<id>`'s score) moved beyond its MDC95 (eq. 7);
        refused when the norms have no MDC95 for it."""
        mdc = self.mdc95(key)
        if mdc is None:
            raise NormsError(f"the norms ({self.source}) have no MDC95 for {key}: add "
                             "test-retest data (`rehab norms mdc`)")
        try:
            real = reliability.is_real_change(float(before), float(after), mdc)
        except (ParameterError, TypeError, ValueError) as exc:
            raise NormsError(f"{key}: {exc}") from None
        return Change(key, float(before), float(after), mdc, real)


def _defined(value: object) -> bool:
    """A figure the trial has: not None, not NaN (a string or an infinity is refused by
    NormativeModel.z, not left out)."""
    return value is not None and not (isinstance(value, float | np.floating)
                                      and math.isnan(value))
