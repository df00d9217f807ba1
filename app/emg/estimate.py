"""The patient's force on the handle estimated from EMG, for the assistance to judge in
place of the force sensor's reading (the thesis's cHRI aim, section 5).

From the newest EMG: the last `HISTORY_S` of each muscle's channel processed as the
model was trained (its file's settings: band-pass, notch, RMS envelope), in fractions of
the session's MVC; those envelopes on the model's own time step up to the newest one;
the model's anatomical torques at that newest step (its activation dynamics and delay
run over the history); the arm's τ_A in absolute angles (core.emg.synthetic.
absolute_torques); and the force those torques imply at the arm's present state, eq. 3.27
solved for F (core.interaction.subject_hand_force).

Only an approved model reaches here (app.emg.modelfile). What the estimate is worth in
closed loop is measured, not assumed: bench/emg_assistance.py and docs/validation.md.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.emg.modelfile import EmgModelFile
from core.emg.models import TrialSet
from core.emg.processing import EmgSettings, as_known, envelope, normalise
from core.emg.synthetic import absolute_torques
from core.errors import ParameterError
from core.interaction import subject_hand_force

HISTORY_S = 1.0
"""How much EMG each estimate is made from: enough for the activation dynamics and the
filters to settle (their time constants are under 0.15 s), little enough to be quick."""


@dataclass(frozen=True, slots=True)
class ArmState:
    """The subject's arm at one tick (the records' subject channels): angles (rad), rates
    (rad/s) and accelerations (rad/s²), absolute."""

    shoulder_rad: float
    elbow_rad: float
    shoulder_rate: float = 0.0
    elbow_rate: float = 0.0
    shoulder_acc: float = 0.0
    elbow_acc: float = 0.0


@dataclass(frozen=True, slots=True)
class Estimate:
    """One estimate: the newest envelope's time (s, the EMG's clock), the anatomical
    torques (shoulder, elbow, N·m) and the hand's force (global frame, N)."""

    time_s: float
    torques_Nm: tuple[float, float]
    force_N: tuple[float, float]


class ForceEstimator:
    """A fitted EMG-to-torque model (core.emg.models), the muscles it takes, the EMG
    processing and envelope step it was trained with, the session's MVC per muscle and
    the EMG channel of each, and the subject's arm model."""

    def __init__(self, model, muscles, settings: EmgSettings, dt_s: float,
                 mvc_V: dict[str, float], channels: dict[str, int], rate_hz: float,
                 arm, *, as_live: bool = False) -> None:
        missing = [m for m in muscles if m not in mvc_V or m not in channels]
        if missing:
            raise ParameterError("mvc_V", sorted(mvc_V), "an MVC and a channel for each of "
                                 + ", ".join(muscles),
                                 f"record the MVC of {', '.join(missing)} first")
        self.model, self.muscles, self.settings = model, tuple(muscles), settings
        self.mvc = np.array([mvc_V[m] for m in muscles], dtype=float)
        self.columns = [channels[m] for m in muscles]
        self.rate_hz = float(rate_hz)
        self.arm = arm
        self.dt_s = float(dt_s)
        self.history_samples = round(HISTORY_S * self.rate_hz)
        self.as_live = as_live
        """The model was trained on envelopes stamped at their windows' ends (as_known)."""

    @classmethod
    def of_file(cls, model: EmgModelFile, mvc_V: dict[str, float], channels: dict[str, int],
                rate_hz: float, arm) -> ForceEstimator:
        """The estimator of an approved model file."""
        return cls(model.model, model.muscles, model.settings, model.dt_s, mvc_V, channels,
                   rate_hz, arm, as_live=model.as_live)

    def torques(self, t_s, samples) -> tuple[float, np.ndarray] | None:
        """(the newest envelope's time, anatomical torques (2,)) from the EMG's times (K,)
        and samples (K, channels): the last HISTORY_S of them; None while there is not
        yet one RMS window's worth."""
        t = np.asarray(t_s, dtype=float)[-self.history_samples:]
        x = np.asarray(samples, dtype=float)[-self.history_samples:, self.columns]
        settings = self.settings
        if t.size < round(settings.window_s * self.rate_hz) + 1 or t.size < 32:
            return None
        env = envelope(x, self.rate_hz, settings, t0_s=float(t[0]))
        if self.as_live:
            env = as_known(env, self.rate_hz, settings)
        u = normalise(env.values, self.mvc)
        grid = np.arange(env.t_s[-1], env.t_s[0] - 1e-12, -self.dt_s)[::-1]
        resampled = np.column_stack([np.interp(grid, env.t_s, u[:, j])
                                     for j in range(u.shape[1])])
        predicted = self.model.predict(TrialSet(resampled, np.zeros((grid.size, 2)), 0,
                                                      "live", self.dt_s))
        return float(grid[-1]), predicted[-1]

    def force(self, torques_Nm, arm: ArmState) -> tuple[float, float]:
        """The hand's force (global frame, N) the anatomical torques imply at `arm`."""
        tau_s, tau_e = absolute_torques(torques_Nm)
        fx, fy, _ = subject_hand_force(self.arm, arm.shoulder_rad, arm.elbow_rad,
                                       arm.shoulder_rate, arm.elbow_rate, arm.shoulder_acc,
                                       arm.elbow_acc, float(tau_s), float(tau_e))
        return float(fx), float(fy)

    def estimate(self, t_s, samples, arm: ArmState) -> Estimate | None:
        made = self.torques(t_s, samples)
        if made is None:
            return None
        time_s, torques = made
        return Estimate(time_s, (float(torques[0]), float(torques[1])),
                        self.force(torques, arm))


HOP_S = 0.0625
"""How often the console makes an estimate: the thesis's envelope step."""


def replay_trial(model, muscles, settings: EmgSettings, dt_s: float, path,
                 hop_s: float = HOP_S, as_live: bool = False, latency_s: float = 0.0):
    """The estimates a model would have given live during a recorded trial with EMG and
    its MVCs (the file's `/emg`): every `hop_s` of the exercise, from the EMG that had
    arrived by that tick only (recorded up to `latency_s` before it: how late the live
    source delivers a sample), at the arm's state of that tick. Returns (the ticks' indices, the
    estimated forces (K, 2), the sensor's forces and the desired directions there, the
    trial's tolerance)."""
    from app.emg.session import trial_emg
    from app.trials.reader import read_trial

    trial = read_trial(path)
    emg = trial_emg(path)
    absent = [m for m in muscles if m not in emg.muscles]
    if absent:
        raise ParameterError("muscles", list(emg.muscles), "the model's " + ", ".join(muscles),
                             f"the trial has no EMG of {', '.join(absent)}")
    mvc = {m: float(emg.mvc[m]["value_V"]) for m in muscles if m in emg.mvc}
    estimator = ForceEstimator(model, muscles, settings, dt_s, mvc,
                               {m: emg.muscles.index(m) for m in muscles}, emg.rate_hz,
                               trial.parameters.arm(), as_live=as_live)
    ch = trial.channels
    exercise = np.flatnonzero(ch["phase"] == 2)
    hop = max(1, round(hop_s / trial.sample_period_s))
    ticks, forces = exercise[::hop], []
    ends = np.searchsorted(emg.time_s, ch["time"][ticks] - latency_s, side="right")
    for k, end in zip(ticks, ends, strict=True):
        state = ArmState(*(float(v) for v in (*ch["subject_angle"][k], *ch["subject_rate"][k],
                                              *ch["subject_acceleration"][k])))
        made = estimator.estimate(emg.time_s[:end], emg.samples[:end], state)
        forces.append((np.nan, np.nan) if made is None else made.force_N)
    return (ticks, np.asarray(forces, dtype=float).reshape(-1, 2), ch["force"][ticks],
            ch["direction_desired"][ticks], trial.parameters.tolerance_rad)
