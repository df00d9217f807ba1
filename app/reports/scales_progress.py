"""A robot figure against a clinical scale over a patient's sessions, and across a study's
patients, with their correlation: the thesis's aim of relating the robot's measures of
performance to the Fugl-Meyer assessment (section 3.6.1), for any figure and scale.

* Per session: the figure is the mean over the session's trials that hold it (finite)
  and measure it, trials marked invalid left out unless asked. An assessment task's trial
  measures only its task's own figures (core.assessment.task_figures, as the Progress tab
  offers them): its file holds the tracking figures too, against a reference that moves
  at the task's pace (or, for the strength task, holds still), and "RMSE x" of a session
  of the battery and a plan was the mean of all of them; the scale is the session's latest entry
  (app.records.registry.clinical). A session with only one of the two is not a point.
* Across a study: one point per patient, the latest session holding both (a patient's
  sessions are not independent of each other, so they are not pooled).
* The correlation: Pearson's r (linear) and Spearman's rho (monotonic, on ranks: the
  scales are ordinal), each with its two-sided p, and n; undefined (NaN) below 3 points or
  when either side does not vary.
* A change between consecutive sessions is marked real only beyond the figure's MDC95 in
  the norms in use (app.norms: MDC95 = 1.96·√2·SEM); with no norms, or norms without an
  MDC95 for the figure, no change is marked and `mdc_note` says why.
"""

from __future__ import annotations

import datetime
import itertools
import math
from dataclasses import dataclass

import numpy as np
from scipy import stats

from app.records.registry import KEY_PARAMETERS
from app.records.scales import value_label
from app.records.store import RecordStore
from app.reports.metrics_table import ROW_BY_KEY, MetricRow
from app.reports.progress_figure import shown_row
from core.assessment import TASKS
from core.assessment.figures import FIGURES

_ASSESSMENT = KEY_PARAMETERS.index("assessment")


@dataclass(frozen=True)
class Correlation:
    """Pearson's r and Spearman's rho of n pairs, each with its two-sided p."""

    n: int
    pearson_r: float
    pearson_p: float
    spearman_rho: float
    spearman_p: float

    def text(self) -> str:
        if not math.isfinite(self.pearson_r):
            return f"n = {self.n}: too few points (or no variation) for a correlation"
        return (f"Pearson r = {self.pearson_r:.2f} ({_p(self.pearson_p)}), Spearman "
                f"ρ = {self.spearman_rho:.2f} ({_p(self.spearman_p)}), n = {self.n}")


def _p(p: float) -> str:
    return "p n/a" if not math.isfinite(p) else ("p < 0.001" if p < 0.001 else f"p = {p:.3f}")


def correlation(x, y) -> Correlation:
    """Pearson's and Spearman's correlations of the pairs (x[i], y[i]) (scipy.stats)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    n = int(x.size)
    if n < 3 or not (_varies(x) and _varies(y)):
        return Correlation(n, math.nan, math.nan, math.nan, math.nan)
    pearson = stats.pearsonr(x, y)
    spearman = stats.spearmanr(x, y)
    rho = float(spearman.statistic)
    p = _exact_spearman_p(x, y, rho) if n <= EXACT_MAX_N else float(spearman.pvalue)
    return Correlation(n, float(pearson.statistic), float(pearson.pvalue), rho, p)


EXACT_MAX_N = 8
"""Up to this many points Spearman's p is exact (every order of the scale's values, 8! =
40 320): scipy's t approximation gives p = 0 for rho = ±1 at any n, where 4 sessions in
order have p = 2/4! = 0.083."""


def _exact_spearman_p(x: np.ndarray, y: np.ndarray, rho: float) -> float:
    """The two-sided permutation p of Spearman's rho: the share of the orders of y whose
    |rho| reaches the observed one (ties kept as average ranks)."""
    rx = stats.rankdata(x)
    ry = stats.rankdata(y)
    orders = np.array(list(itertools.permutations(range(x.size))))
    permuted = ry[orders]
    dx = rx - rx.mean()
    dy = permuted - permuted.mean(axis=1, keepdims=True)
    rhos = (dy @ dx) / np.sqrt((dx @ dx) * (dy * dy).sum(axis=1))
    return float(np.mean(np.abs(rhos) >= abs(rho) - 1e-12))


def _varies(values: np.ndarray) -> bool:
    """Whether the values vary beyond their rounding: scipy's test for a (nearly) constant
    input, whose correlation would be rounding error (its NearConstantInputWarning)."""
    deviations = values - values.mean()
    return bool(np.linalg.norm(deviations) >= 1e-13 * abs(values.mean())
                and np.ptp(values) > 0)


@dataclass(frozen=True)
class SessionPoint:
    """One session: the figure's mean over its trials, the scale's value, and whether the
    figure's change since the point before is real (None: not judged)."""

    code: str
    session_number: int
    date: datetime.date
    figure: float
    n_trials: int
    scale: float
    real_change: bool | None = None


@dataclass(frozen=True)
class ScaleSeries:
    """A figure against a scale: the points and their correlation."""

    figure_key: str
    scale_key: str
    points: tuple[SessionPoint, ...]
    correlation: Correlation
    mdc_note: str = ""
    """Why no change is marked real or not ('' when marks were judged)."""
    mdc95: float | None = None
    norms_label: str = ""
    """The MDC95 the changes were judged against and the norms' label (NormativeModel.label,
    their source and 'simulated' when they are), when they were judged."""
    reliability_note: str = ""
    """NormativeModel.reliability_note of the figure: said beside the marks (an MDC95 on no
    test-retest reliability was shown as any other)."""

    @property
    def marks(self) -> str:
        """The line saying which changes are real and against which norms, or why none is
        marked: the window's and the progress PDF's."""
        if self.mdc_note or self.mdc95 is None:
            return self.mdc_note
        real = [p.session_number for p in self.points if p.real_change]
        said = (f"a real change (beyond MDC95 {self.mdc95:.3g}) at session "
                f"{', '.join(map(str, real))}" if real else "no change beyond the MDC95")
        nil = f" ({self.reliability_note})" if self.reliability_note else ""
        return f"{said}{nil}; {self.norms_label}"

    @property
    def figure_row(self) -> MetricRow:
        """The figure as it is shown: its label, display unit and scale (shown_row)."""
        return shown_row(self.figure_key)

    @property
    def figure_label(self) -> str:
        return self.figure_row.heading_in_unit

    @property
    def scale_label(self) -> str:
        return value_label(self.scale_key)


def has_label(key: str) -> bool:
    """The figure is one a person is shown (the catalogue's or the report's rows'), not a
    record's bookkeeping (duration_s, tolerance_rad, game_hits: shown_row names a key
    neither knows by the key itself)."""
    return key in FIGURES or key in ROW_BY_KEY


def _session_figures(registry: RecordStore, code: str, key: str, include_invalid: bool
                     ) -> dict[int, tuple[datetime.date, float, int]]:
    values: dict[int, list[float]] = {}
    dates: dict[int, datetime.date] = {}
    for trial in registry.trial_summaries(code, include_invalid=include_invalid):
        value = trial.metrics.get(key)
        if value is not None and math.isfinite(value) and measures(trial, key):
            values.setdefault(trial.session_number, []).append(float(value))
            dates[trial.session_number] = trial.session_date
    return {s: (dates[s], float(np.mean(v)), len(v)) for s, v in values.items()}


def figure_keys(registry: RecordStore, code: str, *, include_invalid: bool = False
                ) -> list[str]:
    """The figures the patient's trials hold, in their first appearance's order."""
    keys: dict[str, None] = {}
    for trial in registry.trial_summaries(code, include_invalid=include_invalid):
        keys.update(dict.fromkeys(k for k, v in trial.metrics.items()
                                  if math.isfinite(v) and measures(trial, k)))
    return list(keys)


def measures(trial, key: str) -> bool:
    """Whether registered trial `trial` (a TrialSummary) measures figure `key`: any figure
    for an exercise or a game, only its task's own for an assessment (module notes)."""
    task = trial.key_parameters[_ASSESSMENT] or ""
    # the catalogue's entry names its task (what task_figures filters on): one lookup, not
    # the whole catalogue scanned for each figure of each trial
    spec = FIGURES.get(key)
    return task not in TASKS or (spec is not None and spec.task == task)


def scale_keys(registry: RecordStore, code: str | None = None) -> list[str]:
    """The scale values recorded for the patient (or anyone in the registry)."""
    per_patient = (registry.study_scales() if code is None
                   else {code: registry.session_scales(code)})
    keys: dict[str, None] = {}
    for sessions in per_patient.values():
        for scales in sessions.values():
            for entry in scales.values():
                keys.update(dict.fromkeys(entry.values()))
    return list(keys)


def scale_series(registry: RecordStore, code: str, figure_key: str, scale_key: str, *,
                 include_invalid: bool = False, norms=None) -> ScaleSeries:
    """The figure against the scale over the patient's sessions (module doc), with the
    changes beyond the MDC95 of `norms` (an app.norms.NormativeModel) marked."""
    figures = _session_figures(registry, code, figure_key, include_invalid)
    scales = registry.session_scales(code)
    points = []
    for session in sorted(figures):
        value = _scale_value(scales.get(session, {}), scale_key)
        if value is None:
            continue
        date, figure, count = figures[session]
        points.append(SessionPoint(code, session, date, figure, count, value))
    points, note = _mark_real_changes(points, figure_key, norms)
    judged = norms is not None and not note
    return ScaleSeries(figure_key, scale_key, tuple(points),
                       correlation([p.figure for p in points], [p.scale for p in points]),
                       note, norms.mdc95(figure_key) if judged else None,
                       norms.label if judged else "",
                       norms.reliability_note(figure_key) if judged else "")


def study_series(registry: RecordStore, figure_key: str, scale_key: str, *,
                 include_invalid: bool = False) -> ScaleSeries:
    """One point per patient (their latest session with both) across the registry."""
    points = []
    for code in registry.study_scales():
        mine = scale_series(registry, code, figure_key, scale_key,
                            include_invalid=include_invalid).points
        if mine:
            points.append(mine[-1])
    return ScaleSeries(figure_key, scale_key, tuple(points),
                       correlation([p.figure for p in points], [p.scale for p in points]),
                       "one point per patient: their latest session with both")


def _scale_value(scales: dict, key: str) -> float | None:
    for entry in scales.values():
        value = entry.values().get(key)
        if value is not None:
            return value
    return None


def _mark_real_changes(points: list[SessionPoint], key: str, norms
                       ) -> tuple[list[SessionPoint], str]:
    if norms is None:
        return points, "No norms in use: no change is marked real."
    from app.norms import NormsError

    if key not in norms.figures:  # NormsError's line lists every figure they hold
        return points, (f"the norms ({norms.source}) hold no MDC95 for "
                        f"{shown_row(key).heading_in_unit}, not one of their figures: no "
                        "change is marked real")
    try:
        mdc = norms.mdc95(key)
    except NormsError as exc:
        return points, str(exc)
    if mdc is None:
        return points, f"the norms ({norms.source}) have no MDC95 for {key}"
    marked = points[:1]
    for before, after in itertools.pairwise(points):
        change = norms.is_real_change(key, before.figure, after.figure)
        marked.append(SessionPoint(after.code, after.session_number, after.date, after.figure,
                                   after.n_trials, after.scale, change.real))
    return marked, ""


def mdc_text(series: ScaleSeries, norms=None) -> str:
    """The line saying which changes are real and against which norms (ScaleSeries.marks:
    the series keeps the MDC95 and the norms' label it was judged with)."""
    return series.marks


DERIVED = {"rmse": ("rmse_x_m", "rmse_y_m")}
"""A success figure the registry does not store, and the stored figures it is made of."""


def report_series(registry: RecordStore, progress, *, include_invalid: bool = False,
                  norms=None) -> tuple[ScaleSeries, ...]:
    """What a progress report sets against the scales: each exercise's success figure
    (app.reports.progress.Exercise.success_key, once each; an assessment task's series
    none: its transparent mode's RMSE is not what it measures; for the transparent mode's
    combined RMSE its two axes') against each scale total recorded (Fugl-Meyer, ARAT,
    pain, fatigue), where they share sessions."""
    from app.records.scales import SCALE_MAXIMA

    totals = [k for k in scale_keys(registry, progress.patient_code) if k in SCALE_MAXIMA]
    stored = set(figure_keys(registry, progress.patient_code, include_invalid=include_invalid))
    wanted: dict[str, None] = {}
    for exercise in progress.exercises:
        if exercise.assessment:  # a task's mode is its protocol's, not a success figure
            continue
        # the transparent mode's headline, the two axes' RMSE combined, is not stored: its
        # two stored figures stand for it
        key = exercise.success_key
        wanted.update(dict.fromkeys(DERIVED.get(key, (key,))))
    out = []
    for key in (k for k in wanted if k in stored):
        for scale in totals:
            series = scale_series(registry, progress.patient_code, key, scale,
                                  include_invalid=include_invalid, norms=norms)
            if series.points:
                out.append(series)
    return tuple(out)
