"""Fitting a normative model from a study's own healthy controls, with its cross-validated
calibration, into the documented file (app.norms.modelfile; docs/norms.md, "Fitting").

The controls come as a table, one row per person: their covariates and figures
(`read_controls_table`, a CSV a study keeps), or from a folder of their assessment trial
files (app.norms.controls). Every figure of core.assessment.FIGURES the controls have is
fitted (at least MIN_CONTROLS people with it); every task whose figures all are gets a
task score. The calibration (core.norms.fitting.cross_validate) goes into the file and is
printed by `rehab norms fit` and `rehab norms show`.
"""

from __future__ import annotations

import csv
import difflib
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from app.norms.model import NormsError
from app.norms.modelfile import FORMAT, FORMAT_VERSION
from core.errors import CoreError
from core.norms import fitting
from core.norms.regression import AGE, CATEGORICAL, COVARIATES, Covariates
from core.norms.scores import BETTER_TO_WORSE
from core.norms.transforms import REJECTED

MAX_BOUNDED_FRACTION = 0.05
"""A figure that is a lower bound (FigureSpec.bounded_by: the robot's force limit reached)
in more of the controls than this is not normed: its spread would be the robot's limit,
not the controls' (ours; 5 %, below which a bound moves a fitted quantile little)."""

MIN_CONTROLS = 20
"""Fewer healthy people than this give no usable spread or transform: a figure with fewer
is left out (and said so)."""
MIN_LEVEL_CONTROLS = 5
"""A covariate's level (left-handed, a robot) needs this many controls to estimate its
coefficient; fewer are left out of the fit (and said)."""
MAX_TABLE_BYTES = 64 * 2**20
SUBJECT = "subject"
SESSION = "session"


@dataclass(frozen=True)
class Controls:
    """Healthy controls: one row per person, their covariates and their figures (NaN where
    a person lacks one)."""

    subjects: tuple[str, ...]
    people: tuple[Covariates, ...]
    figures: Mapping[str, np.ndarray]

    def __post_init__(self) -> None:
        for key, values in self.figures.items():
            if len(values) != len(self.people):
                raise NormsError(f"controls: {key} has {len(values)} values for "
                                 f"{len(self.people)} people")


def _catalogue():
    from core.assessment import FIGURES, TASKS

    return FIGURES, TASKS


def read_controls_table(path: str | Path, *, sessions: bool = False) -> Controls:
    """A CSV of controls: a header `subject,age_years,sex,handedness,tested_side,robot,`
    then figure keys (core.assessment.FIGURES), one row per person; an empty cell is a
    figure the person lacks. With `sessions` (test-retest data, `rehab norms mdc`), a
    `session` column too and two rows per person, sessions 1 and 2; `subjects` are then
    `<subject>#<session>`. Every bad cell is refused naming its line and column."""
    from device.safeinput import check_file

    path = check_file(path, what="controls table", max_bytes=MAX_TABLE_BYTES)
    rows = csv_rows(path, "controls table", "a header and one row per healthy person")
    header = [h.strip() for h in rows[0]]
    figures, _ = _catalogue()
    needed = [SUBJECT, *([SESSION] if sessions else []), *COVARIATES]
    missing = [c for c in needed if c not in header]
    if missing:
        raise NormsError(f"controls table {path}: the header lacks {missing[0]!r} (it needs "
                         f"{', '.join(needed)}, then figure keys)")
    unknown = [h for h in header if h not in needed and h not in figures]
    if unknown:
        near = difflib.get_close_matches(unknown[0], [*needed, *figures], n=1, cutoff=0.6)
        hint = f"did you mean {near[0]!r}? " if near else ""
        raise NormsError(f"controls table {path}: column {unknown[0]!r} is neither a "
                         f"covariate nor a figure this console measures ({hint}the figure "
                         "keys: `rehab assess tasks`, docs/assessments.md)")
    if len(set(header)) != len(header):
        raise NormsError(f"controls table {path}: a column appears twice in the header")
    keys = [h for h in header if h in figures]
    subjects, people, values = [], [], {k: [] for k in keys}
    for line, row in enumerate(rows[1:], start=2):
        if not any(cell.strip() for cell in row):
            continue
        if len(row) != len(header):
            raise NormsError(f"controls table {path}, line {line}: {len(row)} cells for "
                             f"{len(header)} columns")
        cells = dict(zip(header, (c.strip() for c in row), strict=True))
        where = f"controls table {path}, line {line}"
        if not cells[SUBJECT]:
            raise NormsError(f"{where}: the subject is empty; give each person a code")
        name = cells[SUBJECT]
        if sessions:
            if cells[SESSION] not in ("1", "2"):
                raise NormsError(f"{where}: session {cells[SESSION][:10]!r} is not 1 or 2 "
                                 "(test and retest)")
            name = f"{name}#{cells[SESSION]}"
        if name in subjects:
            raise NormsError(f"{where}: subject {cells[SUBJECT]!r} appears twice"
                             f"{' for one session' if sessions else ''}; one row per "
                             f"{'person and session' if sessions else 'person'}")
        age = _number(cells[AGE], f"{where}, {AGE}")
        try:
            person = Covariates(age, *(cells[c] for c in CATEGORICAL))
        except CoreError as exc:
            raise NormsError(f"{where}: {exc}") from None
        subjects.append(name)
        people.append(person)
        for key in keys:
            values[key].append(_figure_value(cells[key], key, where) if cells[key]
                               else math.nan)
    if not people:
        raise NormsError(f"controls table {path}: has no rows; one row per healthy person")
    return Controls(tuple(subjects), tuple(people),
                    {k: np.asarray(v, dtype=float) for k, v in values.items()})


def csv_rows(path: Path, what: str, expected: str) -> list[list[str]]:
    """A CSV table's rows (UTF-8, a byte-order mark allowed), refused in one line when it
    is not CSV text, is empty (`expected`: what it should hold), or has a header of one
    cell holding ';' or a tab: a spreadsheet's "CSV" with another separator (a European
    Excel's uses ';'), which was refused as lacking its first column."""
    try:
        text = path.read_bytes().decode("utf-8-sig")
    except UnicodeDecodeError:
        raise NormsError(f"{what} {path}: is not UTF-8 text; save it as CSV (UTF-8)") from None
    try:
        rows = list(csv.reader(io.StringIO(text)))
    except csv.Error as exc:
        raise NormsError(f"{what} {path}: is not CSV ({exc})") from None
    if not rows:
        raise NormsError(f"{what} {path}: is empty; give {expected}")
    if len(rows[0]) == 1:
        separator = next((name for mark, name in ((";", "semicolons"), ("\t", "tabs"))
                          if mark in rows[0][0]), None)
        if separator is not None:
            raise NormsError(f"{what} {path}: its columns are separated by {separator}, "
                             "not commas; save it as CSV with commas (and '.' as the "
                             "decimal point)")
    return rows


def _figure_value(text: str, key: str, where: str) -> float:
    """A figure's cell: a finite number its definition allows (core.assessment.domain): an
    absolute error of -0.01 m or a ratio of 3 was fitted as if measured (a negative value
    even switched the figure's transform to Yeo-Johnson)."""
    from core.assessment.figures import domain  # as _catalogue: imported when used

    value = _number(text, f"{where}, {key}")
    low, high = domain(key)
    if not low <= value <= high:
        span = f"at least {low:g}" if high == math.inf else f"from {low:g} to {high:g}"
        raise NormsError(f"{where}, {key}: {text[:30]!r} is not a value this figure can take "
                         f"({span}, docs/assessments.md); correct the table")
    return value


def _number(text: str, where: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise NormsError(f"{where}: {text[:30]!r} is not a number") from None
    if not math.isfinite(value):
        raise NormsError(f"{where}: {text[:30]!r} is not a finite number")
    return value


@dataclass(frozen=True)
class FitReport:
    """What the fit produced: the norms document, the calibration, what was left out, and
    notes on what was fitted (a λ at its search bound)."""

    document: dict
    calibration: Mapping[str, fitting.Calibration]
    left_out: Mapping[str, str]
    notes: Mapping[str, str]


def fit_norms(controls: Controls, source: str, *, simulated: bool = False,
              transform: str = "auto", folds: int = 5, seed: int = 0) -> FitReport:
    """The norms document fitted on `controls`, with its k-fold calibration."""
    if not source.strip():
        raise NormsError("the norms' source is empty: say who measured which healthy "
                         "people, when (--source)")
    figures_catalogue, tasks_catalogue = _catalogue()
    left_out: dict[str, str] = {}
    controls = _without_rare_levels(controls, left_out)
    table = {}
    for key, values in controls.figures.items():
        have = int(np.sum(np.isfinite(values)))
        if have < MIN_CONTROLS:
            left_out[key] = f"{have} controls have it, fewer than {MIN_CONTROLS}"
        elif np.ptp(values[np.isfinite(values)]) == 0.0:
            left_out[key] = "every control has the same value: no spread to norm"
        elif (off := _off_the_commonest(values)) < MIN_CONTROLS:
            # a count nearly every healthy person has at 0 (a reach with no reaction: 1 of
            # 482 simulated controls): a Z-score fitted to that is not normal (its held-out
            # SD was 0.09), so it says nothing of a patient
            left_out[key] = (f"only {off} controls differ from the commonest value, fewer "
                             f"than {MIN_CONTROLS}: too little spread to norm")
        elif bounded := _bounded_controls(controls, figures_catalogue.get(key)):
            left_out[key] = (f"{bounded} of {have} controls reached the robot's limit, so "
                             "their values are lower bounds, not theirs: a robot that holds "
                             "more is needed to norm it")
        else:
            table[key] = values
    if not table:
        # the people a rare level left out first: they are why "18 controls have it" when
        # 22 were given
        levels = [k for k in left_out if "=" in k]
        shown = [*levels, *sorted(k for k in left_out if "=" not in k)[:3]]
        kept = f"{len(controls.people)} controls kept; " if levels else ""
        raise NormsError(f"no figure has {MIN_CONTROLS} or more controls with a spread: "
                         f"nothing to fit ({kept}"
                         + "; ".join(f"{k}: {left_out[k]}" for k in shown) + ")")
    worse = {k: BETTER_TO_WORSE[figures_catalogue[k].better] for k in table}
    tasks = {}
    for task in tasks_catalogue:
        combined = task_figures_for_score(task, figures_catalogue)
        normed = tuple(k for k in combined if k in table)
        lacking = ", ".join(k for k in combined if k not in table)
        # A figure every control has the same value of (a healthy population's count of
        # reaches with no reaction: 0) says nothing of a patient against them; the task
        # score combines the others, and its figures in the file say which. Fewer than
        # half of the task's figures is no longer that task's score: left out.
        if combined and 2 * len(normed) >= len(combined):
            tasks[task] = normed
            if lacking:
                left_out[f"task:{task}"] = f"scored without {lacking}"
        elif combined:
            first = next(k for k in combined if k not in table)
            why = left_out.get(first, "not among the controls' figures")
            left_out[f"task:{task}"] = f"lacks {lacking} ({first}: {why})"
    try:
        model = fitting.fit_model(table, controls.people, worse, tasks, transform)
        calibration = fitting.cross_validate(table, controls.people, worse, tasks,
                                             transform, folds=folds, seed=seed)
    except CoreError as exc:
        raise NormsError(f"the controls cannot be fitted: {exc}") from None
    document = norms_from_fit(model, source, simulated, calibration, folds,
                              len(controls.people))
    document["notes"] = left_out_notes(left_out)
    notes = {key: f"its λ is held at the search's bound {f.transform.lam:.3g}, which the "
                  f"controls reject (they would take {f.free_lam:.3g}; likelihood ratio "
                  f"{f.bound_cost:.1f} > {REJECTED:.2f}; docs/norms.md, Transform): the "
                  "transform leaves them skewed; check its calibration"
             for key, f in model.figures.items() if f.at_bound}
    return FitReport(document, calibration, left_out, notes)


def _off_the_commonest(values: np.ndarray) -> int:
    """How many controls (finite values) differ from the value most of them have; all of
    them when no two share a value (there is no commonest value: counting one person's
    value as it left a continuous figure of exactly MIN_CONTROLS controls out)."""
    known = values[np.isfinite(values)]
    _, counts = np.unique(known, return_counts=True)
    commonest = int(counts.max()) if counts.size else 0
    return int(known.size) if commonest <= 1 else int(known.size - commonest)


def left_out_notes(left_out: Mapping[str, str]) -> str:
    """What the fit left out, as the norms file's notes (NormativeModel.left_out reads it):
    a heading, then one `key: why` a line, within the file's 5000 characters."""
    if not left_out:
        return ""
    text = "Left out by the fit:"
    for key, why in left_out.items():
        line = f"\n{key}: {why}"
        if len(text) + len(line) > 5000 - 40:
            return text + "\n(more: refit with `rehab norms fit` to see them all)"
        text += line
    return text


def _bounded_controls(controls: Controls, spec) -> int:
    """How many controls have `spec`'s figure as a lower bound (its `bounded_by` count above
    0), when more than MAX_BOUNDED_FRACTION of those with the count do; else 0."""
    bound = controls.figures.get(spec.bounded_by) if spec is not None and spec.bounded_by \
        else None
    if bound is None:
        return 0
    known = bound[np.isfinite(bound)]
    bounded = int(np.sum(known > 0))
    return bounded if known.size and bounded > MAX_BOUNDED_FRACTION * known.size else 0


def _without_rare_levels(controls: Controls, left_out: dict[str, str]) -> Controls:
    """The controls without those whose level of a categorical covariate fewer than
    MIN_LEVEL_CONTROLS share (one left-hander's own residual would be the left-handers'
    coefficient): they are left out and said, and the norms refuse such a patient rather
    than score them by one person."""
    keep = np.ones(len(controls.people), dtype=bool)
    for name in CATEGORICAL:
        levels = [getattr(p, name) for p in controls.people]
        for level in sorted(set(levels)):
            count = levels.count(level)
            if count < MIN_LEVEL_CONTROLS and count < len(levels):
                keep &= np.array([v != level for v in levels])
                left_out[f"{name}={level}"] = (
                    f"{count} control{'s' if count > 1 else ''} with it, fewer than "
                    f"{MIN_LEVEL_CONTROLS}: left out; the norms refuse such patients")
    if keep.all():
        return controls
    return Controls(tuple(s for s, k in zip(controls.subjects, keep, strict=True) if k),
                    tuple(p for p, k in zip(controls.people, keep, strict=True) if k),
                    {f: v[keep] for f, v in controls.figures.items()})


def task_figures_for_score(task: str, figures_catalogue) -> list[str]:
    """The figures a task's score combines: the task's summary figures (the per-direction
    and per-target breakdowns are left out: they repeat the summary; counts of failed
    reaches are left out: zero in nearly every control, they have no spread to norm)."""
    keys = [spec.key for spec in figures_catalogue.values() if spec.task == task]
    if task == "circle":
        return [k for k in keys if not (k.endswith(("_cw", "_ccw")) or "_cw_" in k
                                        or "_ccw_" in k)]
    if task == "strength":
        return [k for k in keys if k in ("strength_peak_force_n", "strength_mean_force_n")]
    if task == "reaching":
        return [k for k in keys if not k.startswith(("vgr_no_reaction", "vgr_no_movement"))]
    return keys


def norms_from_fit(model: fitting.FittedModel, source: str, simulated: bool,
                   calibration: Mapping[str, fitting.Calibration], folds: int, n: int
                   ) -> dict:
    """The norms document (docs/norms.md) of a fitted model."""
    spec = model.spec
    return {
        "format": FORMAT, "format_version": FORMAT_VERSION,
        "source": source.strip(), "simulated": bool(simulated),
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        "covariates": {AGE: list(spec.age_range),
                       **{c: list(spec.levels[c]) for c in CATEGORICAL}},
        "figures": {key: {
            "transform": {"kind": f.transform.kind, "lambda": f.transform.lam,
                          "shift": f.transform.shift},
            "coefficients": dict(f.regression.coefficients),
            "residual_sd": f.regression.residual_sd, "n": f.regression.n,
            "worse": f.worse,
        } for key, f in model.figures.items()},
        "tasks": {task: {
            "figures": list(t.figures),
            "transform": {"kind": t.transform.kind, "lambda": t.transform.lam,
                          "shift": t.transform.shift},
            "mean": t.mean, "sd": t.sd, "n": t.n,
        } for task, t in model.tasks.items()},
        "calibration": {"method": f"{folds}-fold cross-validation over {n} controls",
                        "held_out": {k: c.as_dict() for k, c in calibration.items()}},
    }


def calibration_lines(calibration: Mapping[str, Mapping]) -> list[str]:
    """The calibration as a table for the terminal."""
    lines = [f"{'figure or task score':<36} {'n':>5} {'mean':>7} {'SD':>6} "
             f"{'beyond 1.96':>11} {'QQ max dev':>10}"]
    for key, c in calibration.items():
        missed = c.get("not_scored", 0)
        lines.append(f"{key:<36} {c['n']:>5} {c['mean']:>7.3f} {c['sd']:>6.3f} "
                     f"{100 * c['share_beyond_1_96']:>10.1f}% {c['qq_max_deviation']:>10.3f}"
                     + (f"  ({missed} held out not scorable by their fold)" if missed else ""))
    return lines
