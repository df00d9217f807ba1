"""MDC95 per figure and per task score from test-retest data, added to a norms document
(docs/norms.md, "Minimal detectable change").

The data: each person measured twice (a retest table, app.norms.fitting.read_controls_table
with sessions). Per figure, the people with both sessions give an n × 2 table; ICC(2,1),
SEM and MDC95 in the figure's own units follow (core.norms.reliability, eqs. 5 and 7). Per
task score, each session's score against the norms (with that session's covariates) makes
the table, and the MDC95 is in task-score units.

A person with the figure or the task in one session only, or whom the norms cannot score
(a covariate level the norms' controls lacked, e.g. left-handers left out of a fit with
fewer than 5 of them; a task not performed; a value outside a transform's domain), is
left out of that table and said, with who and why (`RetestReliability.left_out`): a
task's MDC95 from the right-handers alone was printed as if from everyone.
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


def sessions_of(retest: Controls) -> dict[str, tuple[int | None, int | None]]:
    """Person → (row of session 1, row of session 2), None for a session they lack."""
    rows: dict[str, dict[str, int]] = {}
    for i, name in enumerate(retest.subjects):
        person, _, session = name.rpartition("#")
        rows.setdefault(person, {})[session] = i
    return {p: (r.get("1"), r.get("2")) for p, r in rows.items()}


def reliability_of(table) -> Reliability:
    table = np.asarray(table, dtype=float)
    return Reliability(len(table), reliability.icc(table, ICC_FORM),
                       reliability.sem(table, ICC_FORM), reliability.mdc95(table, ICC_FORM))


@dataclass(frozen=True)
class RetestReliability:
    """What `retest_reliability` found: the reliability of each figure and task score
    (`found`), why the others have none (`skipped`), and who each table left out, with
    why (`left_out`: key → one line)."""

    found: dict[str, Reliability]
    skipped: dict[str, str]
    left_out: dict[str, str]


def retest_reliability(model: NormativeModel, retest: Controls) -> RetestReliability:
    """Reliability of each of the norms' figures and task scores the retest data hold,
    why the others have none, and who was left out of each."""
    sessions = sessions_of(retest)
    found: dict[str, Reliability] = {}
    skipped: dict[str, str] = {}
    left_out: dict[str, str] = {}
    for key in model.figures:
        values = retest.figures.get(key)
        if values is None:
            skipped[key] = "not in the retest table"
            continue
        table, left = [], {}
        for person, (a, b) in sessions.items():
            measured = [i is not None and math.isfinite(values[i]) for i in (a, b)]
            if all(measured):
                table.append((values[a], values[b]))
            elif any(measured):
                left[person] = "measured in one session only"
        _add(found, skipped, key, table)
        _say(left_out, key, left, len(table))
    for task, norm in model.tasks.items():
        table, left = [], {}
        for person, (a, b) in sessions.items():
            assessed = [i is not None and bool(_row(retest, i).keys() & set(norm.figures))
                        for i in (a, b)]
            if not any(assessed):
                continue  # not assessed on this task in either session: not a pair
            if not all(assessed):
                left[person] = "assessed in one session only"
                continue
            try:
                table.append(tuple(model.task_score(task, _row(retest, i), retest.people[i])
                                   .score for i in (a, b)))
            except NormsError as exc:
                left[person] = str(exc)
        _add(found, skipped, f"task:{task}", table)
        _say(left_out, f"task:{task}", left, len(table))
    return RetestReliability(found, skipped, left_out)


def _say(left_out: dict[str, str], key: str, left: Mapping[str, str], used: int) -> None:
    """One line: how many of the people were left out of `key`'s table, who, and why
    (each reason once, its people after it)."""
    if not left:
        return
    by_reason: dict[str, list[str]] = {}
    for person, why in left.items():
        by_reason.setdefault(why, []).append(person)
    shown = [f"{why} ({_names(people)})" for why, people in list(by_reason.items())[:3]]
    if len(by_reason) > 3:
        shown.append(f"{len(by_reason) - 3} other reasons")
    left_out[key] = (f"{len(left)} of {len(left) + used} people left out: "
                     + "; ".join(shown))


def _names(people: list[str]) -> str:
    more = len(people) - 5
    return ", ".join(people[:5]) + (f" and {more} more" if more > 0 else "")


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
