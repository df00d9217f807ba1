"""MDC95 per figure and per task score from test-retest data, added to a norms document
(docs/norms.md, "Minimal detectable change").

The data: each person measured twice (a retest table, app.norms.fitting.read_controls_table
with sessions). Per figure, the people with both sessions give an n × 2 table; ICC(2,1),
SEM and MDC95 in the figure's own units follow (core.norms.reliability, eqs. 5 and 7). Per
task score, each session's score against the norms (with that session's covariates) makes
the table, and the MDC95 is in task-score units.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from app.norms.fitting import Controls
from app.norms.model import NormativeModel, NormsError
from core.errors import CoreError
from core.norms import reliability

MIN_PAIRS = 10
"""Fewer test-retest pairs give an ICC too uncertain to mark a change real by."""
ICC_FORM = "2,1"


@dataclass(frozen=True)
class Reliability:
    pairs: int
    icc: float
    sem: float
    mdc95: float


def pairs_of(retest: Controls) -> dict[str, tuple[int, int]]:
    """Person → (row of session 1, row of session 2), for people with both."""
    rows: dict[str, dict[str, int]] = {}
    for i, name in enumerate(retest.subjects):
        person, _, session = name.rpartition("#")
        rows.setdefault(person, {})[session] = i
    return {p: (r["1"], r["2"]) for p, r in rows.items() if "1" in r and "2" in r}


def reliability_of(table) -> Reliability:
    table = np.asarray(table, dtype=float)
    return Reliability(len(table), reliability.icc(table, ICC_FORM),
                       reliability.sem(table, ICC_FORM), reliability.mdc95(table, ICC_FORM))


def retest_reliability(model: NormativeModel, retest: Controls
                       ) -> tuple[dict[str, Reliability], dict[str, str]]:
    """Reliability of each of the norms' figures and task scores the retest data hold,
    and why the others have none."""
    pairs = pairs_of(retest)
    found: dict[str, Reliability] = {}
    skipped: dict[str, str] = {}
    for key in model.figures:
        values = retest.figures.get(key)
        if values is None:
            skipped[key] = "not in the retest table"
            continue
        table = [(values[a], values[b]) for a, b in pairs.values()
                 if math.isfinite(values[a]) and math.isfinite(values[b])]
        _add(found, skipped, key, table)
    for task in model.tasks:
        table = []
        for a, b in pairs.values():
            try:
                table.append(tuple(model.task_score(task, _row(retest, i), retest.people[i])
                                   .score for i in (a, b)))
            except NormsError:
                continue
        _add(found, skipped, f"task:{task}", table)
    return found, skipped


def _row(retest: Controls, i: int) -> dict[str, float]:
    return {k: float(v[i]) for k, v in retest.figures.items() if math.isfinite(v[i])}


def _add(found, skipped, key, table) -> None:
    if len(table) < MIN_PAIRS:
        skipped[key] = f"{len(table)} test-retest pairs, fewer than {MIN_PAIRS}"
        return
    try:
        found[key] = reliability_of(table)
    except CoreError as exc:
        skipped[key] = str(exc)


def with_mdc(document: dict, found: Mapping[str, Reliability]) -> dict:
    """The norms document with each figure's and task's mdc95 and icc set."""
    out = dict(document)
    out["figures"] = {k: dict(v) for k, v in document["figures"].items()}
    out["tasks"] = {k: dict(v) for k, v in document["tasks"].items()}
    for key, r in found.items():
        block = out["tasks"][key[5:]] if key.startswith("task:") else out["figures"][key]
        block["mdc95"] = r.mdc95
        block["icc"] = max(-1.0, min(1.0, r.icc))
    return out
