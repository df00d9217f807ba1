"""A headless trial whose assistance judges the patient's force estimated from EMG: a
synthetic subject's EMG made from the virtual patient's torques while the trial runs,
and the estimate from it given to the loop between ticks, as the live console does.

Every `HOP_S` (the thesis's envelope step, 0.0625 s) of robot time the feed takes the
ticks just run, makes the EMG their net joint torques release (core.emg.synthetic.
EmgStream: causal, the electromechanical delay behind the newest torque), estimates the
torques and the hand's force from the newest second of EMG (app.emg.estimate), and sets
that force on the pipeline for the next ticks (TickPipeline.set_force_estimate). The
trial file then holds the EMG and its MVCs in `/emg` like a recorded trial, and every
estimate in `/assistance` (`estimate_*`, docs/data-format.md) beside the sensor's force,
so how well the estimate agrees with the truth is read off the trial itself.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from app.emg.estimate import ArmState, ForceEstimator
from app.emg.modelfile import EmgModelFile
from core.emg.mvc import mvc_from_contraction
from core.emg.synthetic import MUSCLES, EmgStream, joint_torques, mvc_contraction
from core.errors import ParameterError, check_range

HOP_S = 0.0625
MAX_SECONDS = 1800.0
"""The longest trial the feed keeps the EMG of (46 kB a simulated second for three
muscles): a researcher's trial, not a day's."""


@dataclass
class EstimateLog:
    """Every estimate made: the tick it was set at, the newest envelope's time, the
    anatomical torques and the force (global frame)."""

    tick: list[int] = field(default_factory=list)
    emg_time_s: list[float] = field(default_factory=list)
    torques_Nm: list[tuple[float, float]] = field(default_factory=list)
    force_N: list[tuple[float, float]] = field(default_factory=list)

    def add(self, tick: int, made) -> None:
        """One estimate (app.emg.estimate.Estimate) set at `tick`."""
        self.tick.append(tick)
        self.emg_time_s.append(made.time_s)
        self.torques_Nm.append(made.torques_Nm)
        self.force_N.append(made.force_N)

    def arrays(self) -> dict[str, np.ndarray]:
        return {"tick": np.asarray(self.tick, dtype=np.int64),
                "emg_time": np.asarray(self.emg_time_s, dtype=float),
                "torque": np.asarray(self.torques_Nm, dtype=float).reshape(-1, 2),
                "force": np.asarray(self.force_N, dtype=float).reshape(-1, 2)}

    def entries(self, model: EmgModelFile, hop_s: float, source: str,
                arrays: dict | None = None, **more) -> dict:
        """The trial file's /assistance entries (docs/data-format.md): the model, how
        often and from what, and one row per estimate (`arrays`, default `arrays()`)."""
        arrays = self.arrays() if arrays is None else arrays
        return {"estimate_model": model.name, "estimate_model_sha256": model.content_sha256,
                "estimate_hop_s": hop_s, "estimate_source": source, **more,
                **{f"estimate_{k}": v for k, v in arrays.items()}}


class SyntheticEmgFeed:
    """The feed of the module notes for one synthetic subject (app.emg.subjects.Subject)
    and one approved model; `attach` it to the trial's pipeline, then pass it to the run
    (device.loop.engine.run_trial's `feed`)."""

    def __init__(self, subject, model: EmgModelFile, arm, *, period_s: float,
                 seed: int = 0, session: int = 1) -> None:
        unknown = [m for m in model.muscles if m not in MUSCLES]
        if unknown:
            raise ParameterError("muscles", unknown, ", ".join(MUSCLES))
        self.subject, self.model = subject, model
        self.channels = [MUSCLES.index(m) for m in model.muscles]
        rate = subject.electrodes.rate_hz
        # the session's MVC, one guided contraction per muscle, processed as the model was
        self.mvc = {}
        for muscle in model.muscles:
            _, emg = mvc_contraction(muscle, subject.electrodes,
                                     seed=100 * subject.number + 10 * session
                                     + MUSCLES.index(muscle))
            self.mvc[muscle] = mvc_from_contraction(
                emg[:, MUSCLES.index(muscle)], rate, muscle, settings=model.settings,
                full_scale_V=subject.electrodes.full_scale_V)
        self.estimator = ForceEstimator.of_file(
            model, {m: v.value_V for m, v in self.mvc.items()},
            {m: i for i, m in enumerate(model.muscles)}, rate, arm)
        self.stream = EmgStream(subject.model, subject.electrodes, period_s,
                                seed=10_000 * subject.number + seed)
        self.every_ticks = max(1, round(HOP_S / period_s))
        self.period_s = period_s
        self.log = EstimateLog()
        self._times: list[np.ndarray] = []
        self._samples: list[np.ndarray] = []
        self._pipeline = None

    @staticmethod
    def latency_of(subject) -> float:
        """How late the stream delivers each EMG sample (s): the subject's electromechanical
        delay, since the EMG of a moment is made once the torque it leads is known."""
        return float(subject.model.delay_s)

    @property
    def latency_s(self) -> float:
        return self.latency_of(self.subject)

    def attach(self, pipeline) -> None:
        """The pipeline whose assistance takes the estimates."""
        if not pipeline.assistance.estimated:
            raise ParameterError("pipeline", "a trial on the force sensor",
                                 "a trial that names a force estimate",
                                 "set TrialParameters.force_estimate")
        check_range("trial duration", pipeline.total_ticks * pipeline.period_s, 0.0,
                    MAX_SECONDS, "s", "the feed keeps the trial's EMG; run a shorter trial")
        self._pipeline = pipeline

    def __call__(self, records: np.ndarray) -> None:
        t_emg, emg = self.stream.push(records["time"], joint_torques(
            np.nan_to_num(records["subject_torque"])))
        if t_emg.size:
            self._times.append(t_emg)
            self._samples.append(emg[:, self.channels])
        last = records[-1]
        made = self.estimator.estimate(*self._recent(), ArmState(
            *(float(v) for v in (*last["subject_angle"], *last["subject_rate"],
                                 *last["subject_acceleration"]))))
        tick = int(last["tick"])
        if made is None or not all(map(math.isfinite, made.force_N)):
            self._pipeline.set_force_estimate(math.nan, math.nan, tick)
            return
        self._pipeline.set_force_estimate(*made.force_N, tick)
        self.log.add(tick, made)

    def _recent(self) -> tuple[np.ndarray, np.ndarray]:
        need = self.estimator.history_samples
        times, samples, n = [], [], 0
        for t, x in zip(reversed(self._times), reversed(self._samples), strict=True):
            times.append(t)
            samples.append(x)
            n += t.size
            if n >= need:
                break
        if not times:
            return np.empty(0), np.empty((0, len(self.channels)))
        return np.concatenate(times[::-1]), np.vstack(samples[::-1])

    def assistance_entries(self) -> dict:
        """The estimates for the trial file's /assistance group (docs/data-format.md):
        which model and subject, and one row per estimate."""
        return self.log.entries(self.model, self.every_ticks * self.period_s,
                                "synthetic EMG (app.emg.feed)",
                                estimate_subject=int(self.subject.number))

    def store_emg(self, path: str | os.PathLike) -> None:
        """The trial's EMG and the session's MVCs into the closed trial file's `/emg`."""
        from device.recording.emgfile import write_emg, write_mvc

        if not self._times:
            return
        names = tuple(f"EMG{i + 1}" for i in range(len(self.channels)))
        write_emg(path, names=names, muscles=self.model.muscles,
                  rate_hz=self.subject.electrodes.rate_hz,
                  time_s=np.concatenate(self._times), samples=np.vstack(self._samples),
                  source="synthetic", clock="synthetic: made on the trial's clock",
                  offset_s=0.0)
        write_mvc(path, {m: {**v.to_dict(), "source_file": "synthetic contraction",
                             "channel": names[i], "settings": self.model.settings.to_dict()}
                         for i, (m, v) in enumerate(self.mvc.items())})


