"""The guided MVC protocol of a session, from a live EMG source (section 5.2.1), and the
live envelopes in % of those MVCs while trials run.

Each session starts with one isometric maximal contraction per muscle. The window guides
it: the patient rests (`rest_s`), then pushes as hard as they can for `push_s` while a
countdown runs, then relaxes. The contraction's samples are those the live capture
(device.emg.capture, on its own thread) stamped within the push; the MVC is their
maximum RMS envelope with its quality check (core.emg.mvc: too short, saturated) and,
when the session already has trials with EMG, the check against their activity (lower
than the trial's own activity: subject 2's deltoid). A flagged MVC is said in words and
may be recorded again; the last recording of a muscle is the session's.

`SessionMvcs` keeps them for one patient's session, with the source channel of each
muscle; `store_trial` stores a trial's part of the live capture under the muscles' names
with the session's MVCs in its `/emg/mvc` (app.emg.session.store_mvcs, the same as
`rehab emg mvc`), so the saved trial's envelopes are in % MVC; and `live_percent` gives
the last seconds' envelopes in fractions of those MVCs, processed exactly like them.
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.emg.importing import (
    LIVE_MARGIN_S,
    EmgImportError,
    Imported,
    channel_names,
    import_capture,
    when_free,
)
from app.emg.muscle_words import EFFORT_WORDS, words
from core.emg.mvc import Mvc, MvcCriteria, mvc_from_contraction
from core.emg.processing import EmgSettings, Envelope, envelope
from core.emg.synthetic import THESIS_MUSCLES
from device.emg.emgtext import beyond_range

REST_S = 3.0
PUSH_S = 5.0  # MVC protocols ask for 3–5 s (core.emg.mvc)
SETTLE_S = 2.0  # how long after the push its last samples may still be on their way

REST, PUSH, WAITING, DONE = "rest", "push", "waiting", "done"


@dataclass(frozen=True, slots=True)
class MvcRecord:
    """One muscle's MVC as recorded live: the contraction's own result (too short,
    saturated) and where it came from; the check against trials is made afresh against
    every trial of the session each time one is stored (`store_trial`)."""

    mvc: Mvc
    channel: int  # index in the source's channels, from 0
    source: str
    settings: EmgSettings
    channel_name: str = ""
    """The channel as the trial file names it (the source's label for it,
    app.emg.importing.channel_names); '' for EMG<k>, its place."""


@dataclass(slots=True)
class SessionMvcs:
    """The MVCs of one patient's session, the source channel under each muscle, the
    session's trial files they were stored in, and each MVC's flags as last judged (the
    contraction's own, then against the session's trials: `judged`)."""

    patient: str
    session: int
    channels: dict[str, int] = field(default_factory=lambda: {m: i for i, m in
                                                              enumerate(THESIS_MUSCLES)})
    records: dict[str, MvcRecord] = field(default_factory=dict)
    trials: list[Path] = field(default_factory=list)
    flags: dict[str, tuple[str, ...]] = field(default_factory=dict)

    def copy(self) -> SessionMvcs:
        """A copy another thread may read while this one records the next MVC."""
        return SessionMvcs(self.patient, self.session, dict(self.channels),
                           dict(self.records), list(self.trials), dict(self.flags))

    def belongs_to(self, patient: str, session: int) -> bool:
        return (self.patient, self.session) == (patient, session)

    def measured(self) -> list[tuple]:
        """The MVCs as app.emg.session.store_mvcs takes them: (Mvc, source, channel,
        settings)."""
        return [(r.mvc, r.source, r.channel_name or channel_names((), r.channel + 1)[-1],
                 r.settings) for r in self.records.values()]

    def judged(self, mvc: Mvc) -> None:
        """A muscle's MVC as last checked (by itself, or against the session's trials: a
        trial stored later may flag an MVC recorded ok)."""
        self.flags[mvc.muscle] = tuple(mvc.flags)

    def forget(self, muscle: str) -> bool:
        """The muscle's MVC dropped (its channel changed); whether it had one."""
        self.flags.pop(muscle, None)
        return self.records.pop(muscle, None) is not None

    def flags_of(self, muscle: str) -> tuple[str, ...]:
        """The flags of the muscle's MVC as last judged (its contraction's own until then)."""
        record = self.records[muscle]
        return self.flags.get(muscle, tuple(record.mvc.flags))

    def normalised_muscles(self) -> tuple[str, ...]:
        """The muscles whose MVC is usable, in channel order: one whose MVC is flagged (too
        short, saturated, below the trial's activity) is no reference to read % MVC by
        until it is recorded again (the live view showed it at about 100 % MVC while the
        tab said to record it again)."""
        return tuple(m for m in self.channels if m in self.records and not self.flags_of(m))


@dataclass(frozen=True, slots=True)
class Step:
    phase: str
    remaining_s: float
    text: str


class GuidedMvc:
    """One muscle's guided contraction on an injected clock: rest, push with a countdown,
    then wait for the push's last samples (`ready`)."""

    def __init__(self, muscle: str, *, rest_s: float = REST_S, push_s: float = PUSH_S,
                 clock: Callable[[], float] = time.monotonic) -> None:
        if not (np.isfinite(rest_s) and rest_s >= 0 and np.isfinite(push_s) and push_s > 0):
            raise EmgImportError(f"MVC protocol: rest {rest_s} s, push {push_s} s; give a rest "
                                 "of 0 s or more and a push of more than 0 s")
        self.muscle, self.rest_s, self.push_s, self.clock = muscle, rest_s, push_s, clock
        self.started_s = clock()

    @property
    def rest_span(self) -> tuple[float, float]:
        """Monotonic start and end of the rest before the push: the resting level the push
        must rise above (core.emg.mvc, no effort above rest)."""
        return self.started_s, self.started_s + self.rest_s

    @property
    def push_span(self) -> tuple[float, float]:
        """Monotonic start and end of the push."""
        start = self.started_s + self.rest_s
        return start, start + self.push_s

    def step(self) -> Step:
        now = self.clock()
        start, end = self.push_span
        name = words(self.muscle)
        if now < start:
            return Step(REST, start - now, f"{name}: rest, relaxed ({start - now:.0f} s)")
        if now < end:
            return Step(PUSH, end - now,
                        f"{name}: PUSH as hard as you can: {EFFORT_WORDS.get(self.muscle, '')}"
                        f" … {np.ceil(end - now):.0f} s")
        return Step(WAITING, 0.0, f"{name}: relax.")

    def ready(self, last_stamp_s: float | None) -> bool:
        """The capture has samples up to the push's end."""
        return last_stamp_s is not None and last_stamp_s >= self.push_span[1]

    def late(self) -> bool:
        """The push's last samples did not come within SETTLE_S: the source stalled."""
        return self.clock() > self.push_span[1] + SETTLE_S


def live_range_problem(samples, columns, names, source: str) -> str:
    """What is wrong, in one line, with live samples read in volts that reach a volt
    (device.emg.emgtext.MAX_EMG_V): the source's numbers are in a smaller unit than it was
    read in (an LSL stream of µV opened as lsl:NAME@V, or declaring mV), and an MVC of them
    would be hundreds of volts, said to be ok. '' when nothing is."""
    x = np.asarray(samples, dtype=float)
    for column, name in zip(columns, names, strict=True):
        problem = beyond_range(name, x[:, column], f"in volts as {source} gives them")
        if problem:
            return (f"{problem}: connect the source with the unit its amplifier sends "
                    "(lsl:STREAM_NAME@uV), then record")
    return ""


def check_live_range(samples, columns, names, source: str) -> None:
    """Refuse live samples that reach a volt (live_range_problem)."""
    problem = live_range_problem(samples, columns, names, source)
    if problem:
        raise EmgImportError(problem)


def contraction_mvc(stamps_s, samples, rate_hz: float, muscle: str, channel: int, *,
                    settings: EmgSettings, full_scale_V: float | None,
                    criteria: MvcCriteria | None = None, wanted_s: float,
                    source: str = "the EMG source", rest_samples=None) -> Mvc:
    """The MVC of one muscle from the live samples of its push (core.emg.mvc), refusing a
    push whose samples do not cover most of it (the source dropped out); with
    `rest_samples` (the source's samples of the rest before it, all channels) the push
    must rise above the rest."""
    x = np.asarray(samples, dtype=float)
    if x.ndim != 2 or x.shape[0] < 2:
        raise EmgImportError(f"{words(muscle)}: no EMG came during the contraction; check the "
                             "EMG source's status, then record again")
    if not 0 <= channel < x.shape[1]:
        raise EmgImportError(f"{words(muscle)}: channel {channel + 1} is not in the source "
                             f"(it has channels 1 to {x.shape[1]}); choose its channel")
    covered = x.shape[0] / rate_hz
    if covered < 0.9 * wanted_s:
        raise EmgImportError(f"{words(muscle)}: only {covered:.1f} s of EMG came during the "
                             f"{wanted_s:g} s contraction (the source dropped samples); "
                             "check its status, then record again")
    check_live_range(x, [channel], [f"{words(muscle)} (channel {channel + 1})"], source)
    rest = None
    if rest_samples is not None:
        quiet = np.asarray(rest_samples, dtype=float)
        if quiet.ndim == 2 and quiet.shape[0] >= 2 and channel < quiet.shape[1]:
            rest = quiet[:, channel]
    return mvc_from_contraction(x[:, channel], rate_hz, muscle, settings=settings,
                                full_scale_V=full_scale_V, criteria=criteria, rest=rest)


def store_trial(trial_path: str | os.PathLike, captured, label: str,
                session: SessionMvcs) -> tuple[Imported, dict[str, Mvc]]:
    """A trial's part of the live capture into its `/emg`: the session's muscles' channels
    under their names (app.emg.importing.import_capture), then the session's MVCs checked
    against all its trials so far, this one too, and stored in each (`/emg/mvc`)."""
    from app.emg.session import store_mvcs

    muscles = list(session.channels)
    columns = [session.channels[m] for m in muscles]
    width = captured.samples.shape[1]
    outside = [c + 1 for c in columns if c >= width]
    if outside:
        raise EmgImportError(f"the EMG source has {width} channels, but channel "
                             f"{outside[0]} is chosen for a muscle; choose its channel")
    chosen = dataclasses.replace(captured, samples=captured.samples[:, columns])
    # the channels by the source's own names, as the live view and the chooser show them
    names = channel_names(captured.labels, width)
    done = when_free(lambda: import_capture(
        trial_path, chosen, names=tuple(names[c] for c in columns), muscles=muscles,
        source=label, margin_s=LIVE_MARGIN_S))
    path = Path(trial_path)
    if path not in session.trials:
        session.trials.append(path)
    checked = when_free(lambda: store_mvcs(session.trials, session.measured()))
    return done, checked


def seconds_before_newest(n_samples: int, rate_hz: float) -> float:
    """The first of the live view's `n_samples` in seconds before the newest, on the
    source's own clock (k / rate). Not the span of their stamps: stamps of different reads
    may carry different origins (device.emg.trigno moves its origin earlier as later
    blocks arrive, and only a recording restamps them evenly), so on a loaded machine the
    span came out shorter than the samples and the newest envelope was drawn 0.34 s in
    the future."""
    return -(int(n_samples) - 1) / float(rate_hz)


def live_percent(stamps_s, samples, rate_hz: float, session: SessionMvcs,
                 muscles: tuple[str, ...] | None = None) -> tuple[Envelope, tuple[str, ...]]:
    """The last seconds' envelopes of the session's muscles that have a usable MVC
    (`SessionMvcs.normalised_muscles`), in fractions of it, stamped in seconds before the
    newest sample; processed with the MVCs' own settings (core.emg.processing.envelope),
    as the saved trial will be; `muscles`, some of them (the ones on channels the source
    has)."""
    muscles = session.normalised_muscles() if muscles is None else muscles
    t = np.asarray(stamps_s, dtype=float)
    x = np.asarray(samples, dtype=float)
    if not muscles or t.size < 2:
        return Envelope(np.empty(0), np.empty((0, len(muscles)))), muscles
    records = [session.records[m] for m in muscles]
    # one recording session, one setting: the window records every MVC with the same
    env = envelope(x[:, [session.channels[m] for m in muscles]], rate_hz, records[0].settings,
                   t0_s=seconds_before_newest(x.shape[0], rate_hz))
    return env.normalised(np.array([r.mvc.value_V for r in records])), muscles
