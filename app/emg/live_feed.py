"""The window's estimate of the patient's force while a trial on a force estimate runs:
from the live EMG source (device.emg.capture.EmgCapture) and the session's MVCs, by an
approved model (app.emg.modelfile), at the arm's state of the newest tick the window has
seen, every HOP_S; given to the loop between ticks (DeviceClient.send_force_estimate) by
the window's device thread, never the loop's.

`refusal` says, before a Build, why such a trial cannot run (no source, a muscle without an
MVC, MVCs made with other settings than the model's, a cone narrower than the model was
validated with). While it runs, an EMG older than the model's validated latency (a stalled
or stopped source) gives no estimate: the loop then judges no push and the robot gives
full help; `lost` says so once. After the trial, `assistance_entries` go to the trial
file's /assistance like a headless trial's (app.emg.feed).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

import numpy as np

from app.emg.estimate import HOP_S, ArmState, ForceEstimator
from app.emg.feed import EstimateLog
from app.emg.modelfile import EmgModelFile
from app.emg.muscle_words import words
from app.emg.mvc_words import short_flags


def refusal(model: EmgModelFile, parameters, capture, session) -> str:
    """Why a trial on this model's estimate cannot be built now ("" if it can)."""
    refused = model.refusal(parameters, 0.0)
    if refused:
        return refused
    if capture is None or not capture.running:
        return (f"the trial judges the patient's force by EMG model {model.name}: connect "
                "the EMG source on the EMG tab first")
    missing = [m for m in model.muscles if session is None or m not in session.records]
    if missing:
        return (f"EMG model {model.name} takes {_named(model.muscles)}: record the MVC of "
                f"{_named(missing)} on the EMG tab first")
    # the estimate is read in % of each MVC: one the EMG tab flagged is no reference for it
    flagged = [m for m in model.muscles if session.flags_of(m)]
    if flagged:
        return "; ".join(f"the MVC of {words(m)} is {short_flags(session.flags_of(m))}"
                         for m in flagged) + (f": EMG model {model.name} reads each muscle in "
                                              "% of its MVC, record it again on the EMG tab")
    other = [m for m in model.muscles if session.records[m].settings != model.settings]
    if other:
        return (f"the MVC of {_named(other)} was made with other EMG settings (window, band "
                f"or notch) than EMG model {model.name} was trained with; record it again")
    return ""


def _named(muscles) -> str:
    return ", ".join(words(m) for m in muscles)


class LiveForceFeed:
    """Called with each batch of records the window drains; returns (F_x, F_y, tick) to
    send to the loop at most every HOP_S, else None."""

    def __init__(self, model: EmgModelFile, capture, session, arm, *,
                 clock: Callable[[], float] = time.monotonic) -> None:
        self.model, self.capture, self.clock = model, capture, clock
        channels = {m: session.channels[m] for m in model.muscles}
        mvc = {m: session.records[m].mvc.value_V for m in model.muscles}
        self.estimator = ForceEstimator.of_file(model, mvc, channels, capture.source.rate_hz,
                                                arm)
        self.log = EstimateLog()
        self.lost = ""
        """Why the last estimate could not be made ("" while they come)."""
        self._next = -math.inf
        # the newest sample may be this late and the estimate still be what was validated
        self.max_age_s = model.latency_s + HOP_S

    def __call__(self, records: np.ndarray):
        now = self.clock()
        if not len(records) or now < self._next:
            return None
        self._next = now + HOP_S
        last = records[-1]
        tick = int(last["tick"])
        t, x = self.capture.latest()
        if not self.capture.running or not t.size or now - t[-1] > self.max_age_s:
            # one wording while it lasts, so that the window says it once
            self.lost = (f"no EMG from the source for over {1e3 * self.max_age_s:.0f} ms: the "
                         "assistance gives no way until it comes again (check the EMG tab)")
            return (math.nan, math.nan, tick)
        made = self.estimator.estimate(t, x, ArmState(*(float(v) for v in (
            *last["subject_angle"], *last["subject_rate"], *last["subject_acceleration"]))))
        if made is None or not all(map(math.isfinite, made.force_N)):
            self.lost = "too little EMG yet for an estimate"
            return (math.nan, math.nan, tick)
        self.lost = ""
        self.log.add(tick, made)
        return (*made.force_N, tick)

    def assistance_entries(self, to_trial_time=None) -> dict:
        """The estimates for the trial file's /assistance (docs/data-format.md), the EMG's
        monotonic stamps on the trial's clock by `to_trial_time` (app.emg.importing.
        trial_time_from_monotonic of the closed trial)."""
        arrays = self.log.arrays()
        if to_trial_time is not None and arrays["emg_time"].size:
            arrays["emg_time"] = np.asarray(to_trial_time(arrays["emg_time"]), dtype=float)
        return self.log.entries(self.model, HOP_S, "live EMG (app.emg.live_feed)", arrays)

    def store(self, path) -> int:
        """The estimates into the closed trial file's /assistance; how many."""
        from app.emg.importing import trial_time_from_monotonic
        from app.trials.reader import read_trial
        from device.recording.trialfile import add_assistance

        trial = read_trial(path, channels=("time", "wall_time"))
        add_assistance(path, self.assistance_entries(
            lambda stamps: trial_time_from_monotonic(trial, stamps)))
        return len(self.log.tick)
