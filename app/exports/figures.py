"""Which figures an export writes for a trial: the ones the registry stands by.

A trial's figures are computed when it ends and written twice, into its file's `/metrics`
and into the registry. `rehab reanalyse` (app.trials.reanalyse) later replaces the
registry's with those of today's analysis and never writes the file, whose `/metrics` stay
as recorded. An export of a registered trial therefore writes the registry's figures, the
ones `rehab progress`, the reports and the proposals use, and says whose they are:

* `metrics_source` is ``recorded`` when they are the file's own (a file no registry
  knows, or a registered trial whose figures the registry holds alike), ``registry`` when
  the registry's differ from the file's (re-computed since by `rehab reanalyse`: the
  trial's note in `rehab notes CODE` says by which analysis, who ran it, and each figure's
  old → new);
* the file's own figures are exported beside them (`recorded` in the `_metrics` table,
  `metrics_recorded` in a `.mat`), so nothing the file holds is hidden.

Two figures are the same to rounding as `rehab reanalyse` judges it
(app.trials.reanalyse.same_figure): a figure it kept as stored is never a difference. A
figure the registry lacks is the file's (a trial the registry holds no figures for).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import replace
from types import MappingProxyType

from app.exports.trialinfo import Trial
from app.trials.reanalyse import same_figure

RECORDED = "recorded"
REGISTRY = "registry"
SOURCE_COLUMN = "metrics_source"
"""The column (trials.csv, a `_trial` table's key, a `.mat`'s export field) saying whose
figures the export's are: RECORDED or REGISTRY."""
INVALID_COLUMN = "invalid_reason"
"""The column beside it saying why the registry marks the trial invalid ('' when not), as
`rehab progress --csv` and a study name it."""


def standing_figures(trial: Trial, registry: Mapping[str, float] | None
                     ) -> tuple[Trial, str]:
    """The trial with the figures an export writes, and whose they are (RECORDED or
    REGISTRY): the registry's `registry` figures over the file's own where they differ
    (None: a trial no registry knows, exported with its file's)."""
    if registry is None or not differing(registry, trial.metrics):
        return trial, RECORDED
    return replace(trial, metrics=MappingProxyType({**trial.metrics, **registry})), REGISTRY


def differing(figures: Mapping[str, float], other: Mapping[str, float]) -> tuple[str, ...]:
    """The keys of `figures` whose value `other` does not hold, to rounding (a key `other`
    lacks is none there: NaN)."""
    return tuple(key for key, value in figures.items()
                 if not same_figure(other.get(key, math.nan), value))


def registry_note(count: int) -> str:
    """The export's line for the trials written with the registry's figures."""
    return (f"{count} trial(s) exported with the registry's figures, which differ from "
            f"those in their files (re-computed since by `rehab reanalyse`; `rehab notes "
            f"CODE` says old → new): {SOURCE_COLUMN} says '{REGISTRY}', and each file's "
            "own figures are exported beside them as 'recorded'")
