"""The columns of a study's table and their types, fixed before any file is read.

A Dask dataframe is told its columns before it computes a partition (its `meta`), and every
partition must then have exactly them; Parquet and DuckDB want one type per column across
the whole study. So the columns are derived from the code that makes the values, not from
the files met: the trial's metadata as the researcher's loader names it
(app.exports.loader: `status`, `subject_*`, `parameter_*`…), the assistance it ran
(app.records.outcomes.level_columns), and every metric the console computes, named
`metric_<name>` as in an export's trials.csv: the movement's (core.metrics.TrialMetrics), a
game's (core.games.GameFigures.to_metrics) and an assessment task's (core.assessment.FIGURES).

A row's value of the wrong type for its column (a file from another version) is left out,
and the row's `notes` say so, rather than the study refused. Numbers are SI, as named.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping

import numpy as np
import pandas as pd

from app.exports.trialinfo import flat_parameters
from app.records.outcomes import OUTCOME_COLUMNS
from core.assessment import FIGURES
from core.games.scoring import GameFigures
from core.metrics import TrialMetrics
from core.trial import THESIS_SUBJECT

TEXT, WHOLE, NUMBER, FLAG = "string", "Int64", "float64", "boolean"
"""The column types: pandas' nullable text, whole numbers and flags (missing is <NA>), and
float64 (missing is NaN, as the console's undefined metrics already are)."""

METRIC_PREFIX = "metric_"


def _movement_metrics() -> tuple[str, ...]:
    """TrialMetrics' scalar figures, the keys of its to_dict (its tuples are left out)."""
    return tuple(f.name for f in dataclasses.fields(TrialMetrics)
                 if not str(f.type).startswith("tuple"))


def _game_metrics() -> tuple[str, ...]:
    """GameFigures.to_metrics' keys, from an empty game's figures."""
    empty = GameFigures(**{f.name: "" if f.name == "game" else () if f.name == "outcomes"
                           else 0 for f in dataclasses.fields(GameFigures)})
    return tuple(empty.to_metrics())


METRICS = (*_movement_metrics(), *_game_metrics(), *FIGURES)
"""Every metric a trial's analysis gives (app.trials.analysis.Analysis.to_metrics)."""

_KINDS = {str: TEXT, int: WHOLE, float: NUMBER, bool: FLAG}

LEADING = {
    "patient": TEXT, "site": TEXT, "session": WHOLE, "trial": WHOLE, "trial_id": WHOLE,
    "file": TEXT, "exercise": TEXT, "success_metric": TEXT, "status": TEXT, "seal": TEXT,
    "created_utc": TEXT, "backend": TEXT, "software_version": TEXT, "format_version": WHOLE,
    "n_samples": WHOLE, "sample_period_s": NUMBER, "recorded_s": NUMBER,
    "subject_code": TEXT, "subject_body_mass_kg": NUMBER, "subject_upper_arm_m": NUMBER,
    "subject_forearm_m": NUMBER, "subject_side": TEXT,
}
"""Who, where and which trial, then the file's metadata (app.exports.loader's row keys).
`patient` is the pseudonymous code (from the registry or the console's file name, else the
file's subject code); `site` where the trial was recorded when the study's layout says so
(app.study.sources); `trial_id` the registry's id (none from a folder); `exercise` the
series the trial belongs to in the patient's progress (app.reports.progress.Exercise's
label: the mode, the shape and size, the controller) and `success_metric` that mode's own
success figure."""

PARAMETERS = {name: _KINDS[type(value)]
              for name, value in flat_parameters(THESIS_SUBJECT.to_dict()).items()}
"""`parameter_<name>` for every trial parameter, points split into x and y."""

_OUTCOME_NUMBERS = frozenset((
    "assistance_level_built", "assistance_level_start", "assistance_level_end",
    "proposal_assistance_level", "proposal_duration_s", "proposal_tolerance_rad"))
RAN = {**{name: NUMBER if name in _OUTCOME_NUMBERS else TEXT for name in OUTCOME_COLUMNS},
       "invalid_reason": TEXT}
"""What the trial ran and what followed it, as an export's trials.csv has them
(app.records.outcomes.OUTCOME_COLUMNS, app.exports.run.ran_columns: the levels from its
file; the proposal and its decision from the registry, empty from a folder), and why it
was marked invalid (only with include_invalid)."""

CHECKED = {"registry_differs": TEXT}
"""`registry_differs`: the figures (metric names, ', ' between) whose value in the registry
is not this analysis's: computed by an earlier analysis when the trial ended and not yet
re-analysed, so `rehab progress`, the reports and the exports show the registry's until
`rehab reanalyse` stores these (app.exports.figures); '' where the registry holds these
figures, none for a file no registry knows."""

TRAILING = {"notes": TEXT, "failure": TEXT}
"""`notes`: what the reader recovered and what the analysis left out, ' | ' between;
`failure`: '' for an analysed trial, else why the file could not be analysed."""

COLUMNS: dict[str, str] = {
    **LEADING, **PARAMETERS, **RAN,
    **{METRIC_PREFIX + name: NUMBER for name in METRICS}, **CHECKED, **TRAILING,
}
"""Every column, in order, with its type."""

SORT = ("patient", "session", "trial", "file")
"""The order of the rows written: each patient's trials as their progress lists them."""


def empty_frame() -> pd.DataFrame:
    """No rows, every column typed: a Dask dataframe's `meta`."""
    return pd.DataFrame({name: pd.Series(dtype=kind) for name, kind in COLUMNS.items()})


def frame(rows: list[Mapping]) -> pd.DataFrame:
    """The rows as a typed frame of exactly COLUMNS (a key not in them is dropped; the
    row builder has already noted it)."""
    data = {name: pd.array([row.get(name) for row in rows], dtype=object)
            for name in COLUMNS}
    return pd.DataFrame({name: _typed(values, COLUMNS[name]) for name, values in data.items()})


def _typed(values, kind: str) -> pd.Series:
    if kind == NUMBER:
        return pd.Series(np.array([math.nan if v is None else v for v in values],
                                  dtype=np.float64))
    return pd.Series(values, dtype=object).astype(kind)


def fits(value, kind: str) -> bool:
    """Whether a value can stand in a column of this type (None always can)."""
    if value is None:
        return True
    if kind == TEXT:
        return isinstance(value, str)
    if kind == FLAG:
        return isinstance(value, bool | np.bool_)
    if isinstance(value, bool | np.bool_):
        return False
    if kind == WHOLE:
        return isinstance(value, int | np.integer)
    return isinstance(value, int | float | np.integer | np.floating)

