"""Fitting a normative model from healthy controls, and its cross-validated calibration.

Per figure (transforms.py, regression.py): the transform's λ by the profile likelihood of
the regression on the covariates, then the regression on the transformed scale and its
residual SD. Per task (scores.py): the controls' own Z-scores give their distances D
(eq. 3); a Box-Cox transform of D is fitted (D > 0 always: a distance of exactly 0 needs
every figure at −∞ one-sided), and the transformed distances' mean and SD (ddof 1) are the
task's.

Calibration: k-fold cross-validation. The controls are split into k folds; for each, the
whole model is fitted on the other k − 1 folds and the held-out controls are scored. A
model that generalises gives held-out Z-scores with mean ≈ 0, SD ≈ 1, ~5 % beyond ±1.96,
and task scores with ~5 % above 1.96; the QQ summary is the largest distance between the
sorted held-out Z-scores and the standard normal quantiles at the plotting positions
(i − 0.5)/n over the central 90 % (beyond it a few points always stray).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from core.errors import ParameterError
from core.norms import scores
from core.norms.regression import Covariates, CovariateSpec, Regression, fit_regression
from core.norms.transforms import Transform, fit_transform

TRANSFORM_CHOICES = ("auto", "box-cox", "yeo-johnson", "none")
"""`auto`: Box-Cox (shifted, AUTO_SHIFT_FRACTION) when every control's value is positive,
else Yeo-Johnson."""


@dataclass(frozen=True)
class FittedFigure:
    transform: Transform
    regression: Regression
    worse: str
    at_bound: bool
    """λ is held at a bound of its search that the controls reject (TransformFit
    .bound_rejected); free_lam and bound_cost say what they would take and at what cost."""
    free_lam: float | None = None
    bound_cost: float = 0.0


@dataclass(frozen=True)
class FittedTask:
    figures: tuple[str, ...]
    transform: Transform
    mean: float
    sd: float
    n: int


@dataclass(frozen=True)
class FittedModel:
    spec: CovariateSpec
    figures: Mapping[str, FittedFigure]
    tasks: Mapping[str, FittedTask]

    def z(self, figure: str, values, design: np.ndarray) -> np.ndarray:
        """Eq. (2) for many people at once: `values` one per row of `design`."""
        norm = self.figures[figure]
        beta = np.array([norm.regression.coefficients[c] for c in self.spec.columns])
        t = norm.transform.apply(np.asarray(values, dtype=float))
        return (t - design @ beta) / norm.regression.residual_sd

    def task_scores(self, task: str, values: Mapping[str, np.ndarray], design: np.ndarray
                    ) -> np.ndarray:
        """Eq. (4) for many people at once: `values` figure → one value per row of
        `design`."""
        norm = self.tasks[task]
        z = {f: self.z(f, values[f], design) for f in norm.figures}
        distances = scores.task_distances(z, {f: self.figures[f].worse for f in norm.figures},
                                          norm.figures)
        t = norm.transform.apply(distances)
        return np.asarray(scores.one_sided((t - norm.mean) / norm.sd), dtype=float)


AUTO_SHIFT_FRACTION = 0.01
"""`auto`'s Box-Cox shift, as a fraction of the controls' median: a figure every healthy
person has above 0 (a speed, an area, a force) may be 0 in a patient who does not move,
and Box-Cox with no shift is not defined there (a passive patient's circle speed of 0 was
refused a Z-score); with the shift, 0 is in the domain and scores as far beyond the
controls as it is."""


def choose(choice: str, values: np.ndarray) -> tuple[str, float]:
    """The transform's kind and Box-Cox shift for `choice`: `auto` is Box-Cox on
    x + 1 % of the median when every control's value is positive, else Yeo-Johnson; an
    explicit kind has no shift."""
    if choice not in TRANSFORM_CHOICES:
        raise ParameterError("transform", choice, " | ".join(TRANSFORM_CHOICES))
    if choice != "auto":
        return choice, 0.0
    if np.all(values > 0.0):
        return "box-cox", AUTO_SHIFT_FRACTION * float(np.median(values))
    return "yeo-johnson", 0.0


def fit_figure(values, people: Sequence[Covariates], spec: CovariateSpec, worse: str,
               kind: str | tuple[str, float] = "auto") -> FittedFigure:
    """One figure's transform (λ by the profile likelihood of the regression) and
    regression; `kind` a TRANSFORM_CHOICES or an already chosen (kind, shift)."""
    values = np.asarray(values, dtype=float).reshape(-1)
    if values.size != len(people):
        raise ParameterError("controls' values", values.size, f"{len(people)}, one per control")
    design = spec.design(people)
    chosen, shift = kind if isinstance(kind, tuple) else choose(kind, values)
    fit = fit_transform(chosen, values, design, shift, worse)
    regression = fit_regression(spec, design, fit.transform.apply(values))
    return FittedFigure(fit.transform, regression, worse, fit.bound_rejected, fit.free_lam,
                        fit.bound_cost)


def fit_task(figures: Sequence[str], z_by_figure: Mapping[str, np.ndarray],
             worse: Mapping[str, str]) -> FittedTask:
    """A task's distance transform and its controls' mean and SD, from the controls'
    Z-scores of its figures."""
    distances = scores.task_distances(z_by_figure, worse, figures)
    if not np.all(np.isfinite(distances)) or np.any(distances <= 0.0):
        raise ParameterError("task distances", "a zero or a non-finite one",
                             "positive, finite distances")
    fit = fit_transform("box-cox", distances, worse="higher")  # a greater D is worse
    t = fit.transform.apply(distances)
    return FittedTask(tuple(figures), fit.transform, float(np.mean(t)),
                      float(np.std(t, ddof=1)), int(distances.size))


def fit_model(table: Mapping[str, np.ndarray], people: Sequence[Covariates],
              worse: Mapping[str, str], tasks: Mapping[str, Sequence[str]],
              kind: str | Mapping[str, str | tuple[str, float]] = "auto",
              spec: CovariateSpec | None = None, failed: dict[str, str] | None = None
              ) -> FittedModel:
    """The whole model from the controls: `table` figure → one value per person (NaN for
    a control without it: left out of that figure's fit), `tasks` task → its figures
    (only controls with all of them count for the task).

    A figure that cannot be fitted raises ParameterError; with `failed` (a dict) it is
    recorded there with why and left out instead, with the tasks that need it (`task:<id>`):
    a cross-validation fold whose training controls happen to hold one value of a rare
    figure (every held-out reach with no reaction in the fold left out) loses that figure,
    not every other one."""
    from core.norms.regression import spec_of

    spec = spec or spec_of(people)
    fitted = {}
    for figure, values in table.items():
        values = np.asarray(values, dtype=float)
        keep = np.isfinite(values)
        chosen = kind.get(figure, "auto") if isinstance(kind, Mapping) else kind
        try:
            fitted[figure] = fit_figure(values[keep], [p for p, k in zip(people, keep,
                                                                       strict=True) if k],
                                        spec, worse[figure], chosen)
        except ParameterError as exc:
            if failed is None:
                raise
            failed[figure] = str(exc)
    model = FittedModel(spec, fitted, {})
    design = spec.design(people)
    task_fits = {}
    for task, figures in tasks.items():
        figures = tuple(figures)
        if failed is not None and any(f in failed for f in figures):
            failed[f"task:{task}"] = "needs " + ", ".join(f for f in figures if f in failed)
            continue
        complete = np.all([np.isfinite(np.asarray(table[f], dtype=float)) for f in figures],
                          axis=0)
        z = {f: model.z(f, np.asarray(table[f], dtype=float)[complete], design[complete])
             for f in figures}
        try:
            task_fits[task] = fit_task(figures, z, worse)
        except ParameterError as exc:
            if failed is None:
                raise
            failed[f"task:{task}"] = str(exc)
    return FittedModel(spec, fitted, task_fits)


@dataclass(frozen=True)
class Calibration:
    """Held-out Z-scores' summary for one figure or task."""

    n: int
    mean: float
    sd: float
    beyond_1_96: float
    qq_max_deviation: float
    not_scored: int = 0
    """Held-out controls their fold's model could not score (cross_validate)."""

    def as_dict(self) -> dict:
        return {"n": self.n, "mean": self.mean, "sd": self.sd,
                "share_beyond_1_96": self.beyond_1_96,
                "qq_max_deviation": self.qq_max_deviation, "not_scored": self.not_scored}


def calibration_of(z, one_sided_scores: bool = False) -> Calibration:
    """The summary of held-out Z-scores (or, `one_sided_scores`, of task scores: their
    share above 1.96 and their QQ against the half-normal)."""
    z = np.sort(np.asarray(z, dtype=float))
    n = z.size
    if n < 3:
        raise ParameterError("held-out scores", n, "at least 3")
    p = (np.arange(1, n + 1) - 0.5) / n
    expected = stats.halfnorm.ppf(p) if one_sided_scores else stats.norm.ppf(p)
    central = (p >= 0.05) & (p <= 0.95)
    beyond = np.mean(z > 1.96) if one_sided_scores else np.mean(np.abs(z) > 1.96)
    return Calibration(n, float(np.mean(z)), float(np.std(z, ddof=1)), float(beyond),
                       float(np.max(np.abs(z[central] - expected[central]))))


def cross_validate(table: Mapping[str, np.ndarray], people: Sequence[Covariates],
                   worse: Mapping[str, str], tasks: Mapping[str, Sequence[str]],
                   kind: str | Mapping[str, str] = "auto", folds: int = 5, seed: int = 0
                   ) -> dict[str, Calibration]:
    """k-fold cross-validated calibration: figure → Calibration of its held-out Z-scores,
    `task:<id>` → of its held-out task scores.

    Each fold's model is fitted as the whole model is, on its own training controls: the
    covariate levels those had (the whole model's reference first). A held-out control
    with a level the fold's controls lacked (the only left-hander held out) cannot be
    scored by it, as the norms refuse such a patient; neither can a fold whose controls
    do not determine the regression (its covariates not independent), nor, for one
    figure (and its tasks), a fold whose controls have one value of it. Those controls are
    counted in `Calibration.not_scored`, never scored by guess."""
    from core.norms.regression import spec_of

    n = len(people)
    if not 2 <= folds <= n:
        raise ParameterError("folds", folds, f"2 to {n} (the number of controls)")
    whole = spec_of(people)
    references = {name: levels[0] for name, levels in whole.levels.items()}
    # each figure's kind decided once, on all controls: a fold must not pick Box-Cox for a
    # figure a held-out control has at 0
    kinds = {f: choose(kind.get(f, "auto") if isinstance(kind, Mapping) else kind,
                       np.asarray(v, dtype=float)[np.isfinite(np.asarray(v, dtype=float))])
             for f, v in table.items()}
    order = np.random.default_rng(seed).permutation(n)
    held: dict[str, list[float]] = {}
    missed: dict[str, int] = {}
    for fold in range(folds):
        test = order[fold::folds]
        train = np.setdiff1d(order, test)
        values = {f: np.asarray(v, dtype=float)[test] for f, v in table.items()}
        trained = [people[i] for i in train]
        spec = spec_of(trained, references)
        scorable = np.array([not spec.unknown_levels(people[i]) for i in test], dtype=bool)
        failed: dict[str, str] = {}
        try:
            model = fit_model({f: np.asarray(v, dtype=float)[train] for f, v in table.items()},
                              trained, worse, tasks, kinds, spec, failed)
        except ParameterError:  # the covariates themselves (the regression's design)
            scorable[:] = False
            model = None
        design = spec.design([people[i] for i, ok in zip(test, scorable, strict=True) if ok])
        for figure, v in values.items():
            have = np.isfinite(v)
            fold_has = model is not None and figure not in failed
            missed[figure] = missed.get(figure, 0) + int(np.sum(
                have & (~scorable if fold_has else True)))
            if fold_has:
                held.setdefault(figure, []).extend(model.z(figure, v[have & scorable],
                                                           design[have[scorable]]))
        for task, figures in tasks.items():
            key = f"task:{task}"
            have = np.all([np.isfinite(values[f]) for f in figures], axis=0)
            fold_has = model is not None and key not in failed
            missed[key] = missed.get(key, 0) + int(np.sum(have & (~scorable if fold_has
                                                                   else True)))
            if fold_has:
                held.setdefault(key, []).extend(model.task_scores(
                    task, {f: values[f][have & scorable] for f in figures},
                    design[have[scorable]]))
    out = {}
    for key, z in held.items():
        c = calibration_of(z, key.startswith("task:"))
        out[key] = Calibration(c.n, c.mean, c.sd, c.beyond_1_96, c.qq_max_deviation,
                               missed.get(key, 0))
    return out
