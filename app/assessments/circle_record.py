"""What a circle task's trials record: each trial draws its circle one way round and its
metrics hold that way's figures; the task's figures (both ways' mean, the task score's,
app.assessments.figures.circle_task) are the pair's, which app.assessments.runner stores
in both trials of the pair, with both ways' figures beside them.

A listing of a patient's assessments (`rehab assess run`, `rehab assess show`) shows each
trial's own way and the pair's figures once, naming the trials they come from: shown with
each trial, the task's figures appeared twice. The files and the registry stay as written.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

from core.assessment.figures import CIRCLE_BASE_KEYS, CIRCLE_WAYS, circle_key

WAY_WORDS = {"cw": "clockwise", "ccw": "counter-clockwise"}


def way_of(clockwise: bool) -> str:
    return "cw" if clockwise else "ccw"


def own_figures(metrics: Mapping[str, float], clockwise: bool) -> dict[str, float]:
    """The figures of the circle the trial drew (its way round's), as its metrics hold them."""
    way = way_of(clockwise)
    keys = [circle_key(base, way) for base in CIRCLE_BASE_KEYS]
    return {key: metrics[key] for key in keys if key in metrics}


def pair_figures(metrics: Mapping[str, float]) -> dict[str, float]:
    """The task's figures (both ways' mean) a trial holds; {} when it holds none (a trial run
    alone, as the window runs them, or a fault before either circle)."""
    return {key: metrics[key] for key in CIRCLE_BASE_KEYS if key in metrics}


def _record(metrics: Mapping[str, float]) -> tuple | None:
    """The pair's record a trial holds (the means and both ways' figures), comparable with
    NaN; None without the task's figures."""
    if len(pair_figures(metrics)) < len(CIRCLE_BASE_KEYS):
        return None
    keys = [*CIRCLE_BASE_KEYS,
            *(circle_key(base, way) for way in CIRCLE_WAYS for base in CIRCLE_BASE_KEYS)]
    return tuple("nan" if math.isnan(v) else repr(float(v))
                 for v in (metrics.get(key, math.nan) for key in keys))


def pairs(trials: Sequence[tuple[int, Mapping[str, float]]]) -> dict[int, tuple[int, ...]]:
    """For each circle trial (its id, its metrics) that holds the task's figures, the ids of
    the trials holding the same ones (its pair, itself included, in `trials`' order)."""
    holders: dict[tuple, list[int]] = {}
    for trial_id, metrics in trials:
        record = _record(metrics)
        if record is not None:
            holders.setdefault(record, []).append(trial_id)
    return {trial_id: tuple(ids) for ids in holders.values() for trial_id in ids}


def pair_heading(ids: Sequence[int]) -> str:
    """Which trials the task's figures come from (their registry ids, as the trials'
    headings name them)."""
    named = " and ".join(str(i) for i in ids) if len(ids) > 1 else str(ids[0])
    return f"both ways, from trial id{'s' if len(ids) > 1 else ''} {named}"
