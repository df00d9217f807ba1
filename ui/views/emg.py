"""What the EMG tab shows for a trial file, computed without Qt: each muscle's envelope in
% MVC on the trial's ticks (app.emg.session.trial_envelopes), its MVC's flags, or the one
line that says why there is nothing to show."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.emg.muscle_words import words
from app.emg.mvc_words import short_flags
from app.emg.protocol import live_percent, seconds_before_newest
from app.emg.session import trial_envelopes
from app.errors import AppError
from core.errors import CoreError
from device.errors import DeviceError
from device.recording.emgfile import read_emg


@dataclass(frozen=True, slots=True, eq=False)
class EmgView:
    time_s: np.ndarray = field(default_factory=lambda: np.empty(0))
    percent: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))  # (N, C) % MVC
    muscles: tuple[str, ...] = ()
    flags: dict = field(default_factory=dict)
    message: str = ""
    notes: tuple[str, ...] = ()
    """What the trial file says is wrong with its EMG (device.recording.emgfile, `notes`:
    the capture ended early, samples missing, stamps moved): shown with it, not only
    kept in the file."""

    @property
    def peaks(self) -> dict[str, float]:
        """Each muscle's highest % MVC over the trial."""
        return {m: float(np.nanmax(self.percent[:, i])) if np.isfinite(self.percent[:, i]).any()
                else float("nan") for i, m in enumerate(self.muscles)}


def emg_view(path: Path | None) -> EmgView:
    if path is None:
        return EmgView(message="No trial file yet: EMG shows here once a trial is saved.")
    notes: tuple[str, ...] = ()
    try:
        stored = read_emg(path)
        if stored is None:
            return EmgView(message="This trial has no EMG. To record it with the next "
                                   "trial, connect the EMG source on this tab before "
                                   "Start.")
        notes = stored.notes
        missing = [m for m in stored.muscles if m not in stored.mvc]
        if missing:
            # in the therapist's words: the way in the window is the tab's own protocol
            # (app.emg.session says `rehab emg mvc`, the command line's)
            return EmgView(message=f"This trial has no MVC for {', '.join(missing)}: record "
                                   "each muscle's MVC in the MVC protocol on this tab (a "
                                   "source connected); the session's trials then show in "
                                   "% MVC.", notes=notes)
        env = trial_envelopes(path)
    except (AppError, CoreError, DeviceError) as exc:
        return EmgView(message=str(exc), notes=notes)
    return EmgView(env.time_s, 100.0 * env.values, env.muscles, env.flags, notes=notes)


LIVE_MIN_S = 0.5  # the band-pass's start-up needs some signal before an envelope means much


@dataclass(frozen=True, slots=True, eq=False)
class LiveEmgView:
    """The live source's last seconds as the tab draws them: the muscles the tab assigns a
    channel, each muscle's envelope in % MVC once the session has a usable MVC of it
    (app.emg.protocol.live_percent, processed like the MVC), otherwise their RMS envelopes
    in µV; stamped in s before now. With no muscle assigned, every channel in µV."""

    t_s: np.ndarray
    values: np.ndarray  # (K, C) in `unit`
    names: tuple[str, ...]  # the muscles (their keys), or the channels when none is assigned
    unit: str
    problem: str = ""  # the source's numbers read in too large a unit (one line), or ''
    aside: tuple[str, ...] = ()
    """What streams but is not drawn, a line each: a muscle not in % MVC while others are
    (no MVC yet, or its MVC flagged), a muscle on a channel the source lacks, and the
    channels no muscle is on."""


def live_emg_view(stamps_s, samples, rate_hz: float, session=None,
                  labels=(), source: str = "the EMG source",
                  assigned=None) -> LiveEmgView | None:
    """None until the source has given LIVE_MIN_S of EMG. The muscles drawn are the
    session's (`session.channels`), else `assigned` (muscle -> channel from 0: the tab's
    choosers before a patient is registered); the 16 channels of a base station, most of
    them empty sensors, were drawn until the MVCs. With neither, the channels are named as
    the trial file will keep them (`labels`, the source's own names,
    app.emg.importing.channel_names). Samples that reach a volt are said at once, before
    an MVC is recorded of them (app.emg.protocol.live_range_problem)."""
    from app.emg.importing import channel_names
    from app.emg.protocol import live_range_problem
    from core.emg.processing import rms_envelope

    t = np.asarray(stamps_s, dtype=float)
    if t.size < max(2, round(LIVE_MIN_S * rate_hz)):
        return None
    x = np.asarray(samples, dtype=float)
    width = x.shape[1]
    names = channel_names(labels, width)
    problem = live_range_problem(x, range(width), names, source)
    muscles = dict(session.channels if session is not None else assigned or {})
    drawn = {m: c for m, c in muscles.items() if 0 <= c < width}
    aside = [f"{words(m)}: its channel {c + 1} is not in the source (channels 1 to {width})"
             for m, c in muscles.items() if m not in drawn]
    normalised = tuple(m for m in (session.normalised_muscles() if session is not None
                                   else ()) if m in drawn)
    try:
        if normalised:
            env, _ = live_percent(t, x, rate_hz, session, normalised)
            aside += [_not_normalised(m, session) for m in drawn if m not in normalised]
            shown, unit, values = normalised, "% MVC", 100.0 * env.values
        else:
            columns = list(drawn.values()) if muscles else list(range(width))
            shown = tuple(drawn) if muscles else tuple(names)
            env = rms_envelope(x[:, columns] - x[:, columns].mean(axis=0), rate_hz,
                               t0_s=seconds_before_newest(x.shape[0], rate_hz))
            unit, values = "µV", 1e6 * env.values
    except CoreError:  # too little signal yet for the filters: the next refresh will do
        return None
    free = sorted(set(range(width)) - set(drawn.values()))
    if muscles and free:
        aside.append(f"{_spans(free)} streaming, not on a muscle: not drawn")
    return LiveEmgView(env.t_s, values, shown, unit, problem, tuple(aside))


def _not_normalised(muscle: str, session) -> str:
    """Why a muscle is not drawn while the others are in % MVC."""
    if muscle not in session.records:
        return f"{words(muscle)}: no MVC yet, not drawn in % MVC"
    return (f"{words(muscle)}: not drawn, its MVC is {short_flags(session.flags_of(muscle))}"
            ": record it again")


def _spans(channels: list[int]) -> str:
    """Channels from 0 as the tab numbers them: 'channel 4', 'channels 1, 4–16'."""
    runs: list[list[int]] = []
    for c in channels:
        if runs and c == runs[-1][-1] + 1:
            runs[-1].append(c)
        else:
            runs.append([c])
    text = ", ".join(f"{r[0] + 1}–{r[-1] + 1}" if len(r) > 1 else f"{r[0] + 1}" for r in runs)
    return f"channel{'s' if len(channels) > 1 else ''} {text}"
