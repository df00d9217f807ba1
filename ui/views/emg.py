"""What the EMG tab shows for a trial file, computed without Qt: each muscle's envelope in
% MVC on the trial's ticks (app.emg.session.trial_envelopes), its MVC's flags, or the one
line that says why there is nothing to show."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

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
    """The live source's last seconds as the tab draws them: each muscle's envelope in
    % MVC once the session has its MVC (app.emg.protocol.live_percent, processed like the
    MVC), otherwise each channel's RMS envelope in µV; stamped in s before now."""

    t_s: np.ndarray
    values: np.ndarray  # (K, C) in `unit`
    names: tuple[str, ...]
    unit: str
    problem: str = ""  # the source's numbers read in too large a unit (one line), or ''


def live_emg_view(stamps_s, samples, rate_hz: float, session=None,
                  labels=(), source: str = "the EMG source") -> LiveEmgView | None:
    """None until the source has given LIVE_MIN_S of EMG. Without the session's MVCs, the
    channels are named as the trial file will keep them (`labels`, the source's own names,
    app.emg.importing.channel_names). Samples that reach a volt are said at once, before
    an MVC is recorded of them (app.emg.protocol.live_range_problem)."""
    from app.emg.importing import channel_names
    from app.emg.protocol import live_percent, live_range_problem, seconds_before_newest
    from core.emg.processing import rms_envelope

    t = np.asarray(stamps_s, dtype=float)
    if t.size < max(2, round(LIVE_MIN_S * rate_hz)):
        return None
    x = np.asarray(samples, dtype=float)
    names = channel_names(labels, x.shape[1])
    problem = live_range_problem(x, range(x.shape[1]), names, source)
    try:
        mapped = session.muscles_with_mvc() if session is not None else ()
        if mapped and all(session.channels[m] < x.shape[1] for m in mapped):
            env, muscles = live_percent(t, x, rate_hz, session)
            return LiveEmgView(env.t_s, 100.0 * env.values, muscles, "% MVC", problem)
        env = rms_envelope(x - x.mean(axis=0), rate_hz,
                           t0_s=seconds_before_newest(x.shape[0], rate_hz))
    except CoreError:  # too little signal yet for the filters: the next refresh will do
        return None
    return LiveEmgView(env.t_s, 1e6 * env.values, names, "µV", problem)
