"""Trials for the report tests, made by the simulator (app.trials.headless) and registered
as the window registers them: complete, cut short (stopped, faulted, e-stopped), or with
the assistance level changed during the exercise."""

from __future__ import annotations

import dataclasses
import datetime

import numpy as np
from pypdf import PdfReader

from app.records.registry import Registry
from app.trials.finalize import finalize_trial
from app.trials.headless import save, simulate
from core.trial import TrialParameters
from device.loop.pipeline import PHASE_EXERCISE
from device.safety.faults import Fault

T0 = datetime.datetime(2026, 5, 4, 9, 0, tzinfo=datetime.UTC)


def cut(trial, fraction: float, status: str, fault: Fault = Fault.ESTOP):
    """The simulated trial ended after `fraction` of its ticks: by `fault` (an e-stop by
    default: the loop's event, values and banner) or by the therapist."""
    n = int(len(trial.records) * fraction)
    if status == "faulted":
        detail = {"fault": fault.label, "code": int(fault)}
        last = {"time_s": n * 0.002, "tick": n, "kind": "fault",
                "message": fault.banner(detail), "values": detail}
    else:
        last = {"time_s": n * 0.002, "tick": n, "kind": "stop",
                "message": "stopped by the therapist", "values": {}}
    events = (*[e for e in trial.events if e["kind"] == "start"], last)
    return dataclasses.replace(trial, records=trial.records[:n], events=events, status=status)


def exercise_start_s(trial) -> float:
    phase = trial.records["phase"]
    return float(trial.records["time"][np.flatnonzero(phase == PHASE_EXERCISE)[0]])


def with_live_change(trial, after_s: float, level: float):
    """The trial's file as the loop writes one whose level the therapist changed `after_s`
    into the exercise: an `assistance` event and, when the record has it, the per-tick
    level from then on (docs/data-format.md)."""
    start = exercise_start_s(trial)
    tick = round((start + after_s) / trial.plan.period_s)
    records = trial.records.copy()
    if "assistance_level" in records.dtype.names:
        records["assistance_level"][tick:] = level
    event = {"time_s": tick * trial.plan.period_s, "tick": tick, "kind": "assistance",
             "message": f"assistance level set to {level:.0%}", "values": {"level": level}}
    events = sorted((*trial.events, event), key=lambda e: e["tick"])
    return dataclasses.replace(trial, records=records, events=tuple(events))


def register(registry: Registry, code: str, parameters: TrialParameters, *, session: int,
             patient: str = "weak", seed: int = 1, minutes: float = 0.0, edit=None) -> int:
    """Simulate, save, register and finish one trial (`edit` changes the simulated trial
    before it is written: `cut`, `with_live_change`); returns its id."""
    trial = simulate(parameters, patient=patient, seed=seed)
    if edit is not None:
        trial = edit(trial)
    started = T0 + datetime.timedelta(minutes=minutes)
    begun = registry.begin_trial(code, parameters, backend="simulator",
                                 session_number=session, patient_kind=patient,
                                 started_at=started)
    # finished as the window finishes a trial: the file's levels and last fault kept
    finalize_trial(registry, begun.trial_id,
                   analysis=save(trial, begun.path, subject_code=code))
    return begun.trial_id


def page_texts(path) -> list[str]:
    return [" ".join(page.extract_text().split()) for page in PdfReader(path).pages]


def placed_texts(path, page: int) -> list[tuple[float, float, str]]:
    """Every text fragment of a PDF page with its position (x, y in points)."""
    placed = []

    def visit(text, cm, tm, font, size):
        if text.strip():
            placed.append((round(cm[4] + tm[4], 1), round(cm[5] + tm[5], 1), text.strip()))

    PdfReader(path).pages[page].extract_text(visitor_text=visit)
    return placed


def staircase_course(registry: Registry, code: str, parameters: TrialParameters) -> dict:
    """An as-needed course whose help steps down trial by trial (100, 90, 80 %, the pace
    from 4 s to 3.6 s a lap at the third), lowered live from 80 % to 70 % 1 s into the
    fourth, ended by the emergency stop in the fifth; then two thesis-mode trials. Returns
    the trials' ids by name."""
    as_needed = parameters.replace(assist="as-needed")
    thesis = parameters.replace(assist="thesis")
    steps = (
        ("100", as_needed, 1, None),
        ("90", as_needed.replace(assistance_level=0.9), 1, None),
        ("80 faster", as_needed.replace(assistance_level=0.8, duration_s=3.6), 1, None),
        ("80 to 70", as_needed.replace(assistance_level=0.8, duration_s=3.6), 2,
         lambda trial: with_live_change(trial, 1.0, 0.7)),
        ("70 e-stopped", as_needed.replace(assistance_level=0.7, duration_s=3.6), 2,
         lambda trial: cut(trial, 0.6, "faulted")),
        ("thesis 1", thesis, 2, None),
        ("thesis 2", thesis, 2, None),
    )
    return {name: register(registry, code, p, session=session, seed=k + 1, minutes=5 * k,
                           edit=edit)
            for k, (name, p, session, edit) in enumerate(steps)}
