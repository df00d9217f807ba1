"""Trials for the report tests, made by the simulator (app.trials.headless) and registered
as the window registers them: complete, cut short (stopped, faulted, e-stopped), or with
the assistance level changed during the exercise."""

from __future__ import annotations

import dataclasses
import datetime
import functools
import math

import numpy as np
from matplotlib.font_manager import FontProperties
from matplotlib.textpath import TextToPath
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


def many_trials(registry: Registry, code: str, n: int, pace_s) -> None:
    """`n` complete thesis-mode trials of the D, ten a session, registered with a figure and
    no file (Progress reads the registry), the k-th at `pace_s(k)` s a lap: a patient's
    hundreds of trials in a second or two."""
    from core.trial import THESIS_SUBJECT

    for k in range(n):
        begun = registry.begin_trial(code, THESIS_SUBJECT.replace(duration_s=pace_s(k)),
                                     backend="simulator", session_number=1 + k // 10)
        registry.finish_trial(begun.trial_id, "complete",
                              {"directional_performance_pct": 60.0 + k % 7})


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


@dataclasses.dataclass(frozen=True)
class InkBox:
    """Where a text's ink lies on its page, in points from the page's bottom left."""

    page: int  # from 1
    text: str
    left: float
    right: float
    bottom: float
    top: float


# DejaVu Sans's ink above and below the baseline, in em: 'b', 'd', 'l' reach 0.76, 'g',
# 'p', 'y' 0.236 below.
_ASCENT_EM, _DESCENT_EM = 0.76, 0.24


def ink_boxes(path) -> list[InkBox]:
    """Every text of every page of a PDF with the box its ink takes: placed where the PDF's
    text matrices put it (pypdf's visitor) and as long as DejaVu Sans, the one font the
    report embeds (by the name in the PDF, regular or bold), draws it at the PDF's size.
    A text turned (an axis label) takes its box turned."""
    boxes = []
    for number, page in enumerate(PdfReader(path).pages, start=1):

        def visit(text, cm, tm, font, size, number=number):
            text = text.strip()
            if not text:
                return
            name = str(font["/BaseFont"]) if font is not None else "no font"
            if "DejaVuSans" not in name or "Oblique" in name:
                raise AssertionError(f"page {number}: {text!r} in {name}, not DejaVu Sans")
            a, b, c, d, e, f = _times(tm, cm)
            # the advance along the baseline, the ink across it (the matrix's unit vectors)
            length = _width_em(text, "Bold" in name) * size
            ux, uy = a / math.hypot(a, b), b / math.hypot(a, b)
            vx, vy = c / math.hypot(c, d), d / math.hypot(c, d)
            xs, ys = [], []
            for along in (0.0, length):
                for across in (-_DESCENT_EM * size, _ASCENT_EM * size):
                    xs.append(e + along * ux + across * vx)
                    ys.append(f + along * uy + across * vy)
            boxes.append(InkBox(number, text, min(xs), max(xs), min(ys), max(ys)))

        page.extract_text(visitor_text=visit)
    return boxes


def _times(m, n):
    """The product of two PDF matrices [a b c d e f] (m then n)."""
    a, b, c, d, e, f = (float(x) for x in m)
    p, q, r, s, t, u = (float(x) for x in n)
    return a * p + b * r, a * q + b * s, c * p + d * r, c * q + d * s, \
        e * p + f * r + t, e * q + f * s + u


@functools.lru_cache(maxsize=4096)
def _width_em(text: str, bold: bool) -> float:
    font = FontProperties(family="DejaVu Sans", size=100.0,
                          weight="bold" if bold else "normal")
    width, _, _ = TextToPath().get_text_width_height_descent(text, font, ismath=False)
    return width / 100.0


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
