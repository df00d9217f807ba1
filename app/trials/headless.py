"""A whole trial on the simulator without a screen or a real-time loop, as fast as it runs.

The same per-tick pipeline, safety supervisor and trial file as a live trial; only the
pacing differs (simulated time advances tick by tick instead of waiting for the clock).
Researchers use it to try parameters and virtual patients; the tests use it end to end.

Two engines run the same ticks. "compiled" (device.compiled, numba) runs a usual
trial several hundred times faster than real time; "python" is the reference
implementation the live loop also uses. The default, "auto", takes the compiled
engine and hands the trial to the Python one when the configuration has no compiled
form or a tick leaves the ordinary (a fault): the Python engine replays it from the
start, deterministically, and writes the fault's event with its cause and values.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.trials.analysis import Analysis, analyse
from core.errors import ParameterError
from core.robot import RobotModel
from core.trial import TrialParameters
from device.compiled import trial as compiled
from device.compiled.warmup import load_kernels
from device.errors import BackendError
from device.loop.pipeline import TickPipeline, TrialPlan, fill_subject_channels
from device.loop.states import State
from device.recording.record import RecordLog
from device.recording.trialfile import SubjectInfo, write_trial
from device.safety.supervisor import SafetySupervisor
from device.sim.simulator import SimulatorBackend

Progress = Callable[[float], None]
ENGINES = ("auto", "compiled", "python")


@dataclass(frozen=True, slots=True)
class SimulatedTrial:
    """What a headless run produced, before and after it is written."""

    plan: TrialPlan
    records: np.ndarray
    events: tuple[dict, ...]
    status: str
    patient: str
    seed: int
    elapsed_s: float
    engine: str = "python"
    """Which engine produced the records: "compiled" or "python"."""
    handed_over: str = ""
    """Why an "auto" run left the compiled engine ('' when it did not)."""
    load_s: float = 0.0
    """Time spent loading the compiled kernels before the run (once per process)."""

    @property
    def simulated_s(self) -> float:
        return len(self.records) * self.plan.period_s

    @property
    def speed_vs_real_time(self) -> float:
        return self.simulated_s / self.elapsed_s if self.elapsed_s > 0 else float("inf")


def simulate(
    parameters: TrialParameters,
    *,
    patient: str = "healthy",
    seed: int = 0,
    robot: RobotModel | None = None,
    progress: Progress | None = None,
    patient_options: dict | None = None,
    engine: str = "auto",
) -> SimulatedTrial:
    """Run a trial on the simulator with a virtual patient of kind `patient`.

    Refuses unreachable or absurd parameters before anything runs (TrialPlan.build).
    The safety supervisor watches every tick as in a live trial; a fault (or a
    backend failure, which it turns into one) ends the trial as "faulted" with the
    cause as an event, and the samples up to it are kept.

    `engine` is one of ENGINES (module notes). "compiled" refuses a configuration
    without a compiled form instead of falling back.
    """
    if engine not in ENGINES:
        raise ParameterError("engine", engine, "one of " + ", ".join(ENGINES))
    plan = TrialPlan.build(parameters, robot)
    # the simulator's dynamics are compiled in both engines; load before anything is timed
    load_s = load_kernels(("simulator",) if engine == "python" else ("simulator", "headless"))
    backend = SimulatorBackend.from_trial(
        parameters, patient, seed=seed, robot=plan.robot, patient_options=patient_options
    )
    pipeline = TickPipeline(plan)
    supervisor = SafetySupervisor(plan.robot)
    started = time.perf_counter()
    handed_over = ""
    if engine != "python":
        outcome = compiled.run(backend, pipeline, supervisor, progress)
        if isinstance(outcome, np.ndarray):
            return _finish(plan, outcome, [
                _event(0, plan.period_s, "start", "trial started",
                       {"patient": patient, "seed": seed}),
                _event(len(outcome), plan.period_s, "stop", "trial complete", {}),
            ], "complete", patient, seed, started, "compiled", "", progress, load_s)
        if engine == "compiled" and outcome.tick == 0:
            raise ParameterError("engine", engine, "a configuration with a compiled form",
                                 outcome.reason)
        handed_over = f"tick {outcome.tick}: {outcome.reason}"
    log = RecordLog()
    events: list[dict] = []
    status = "complete"
    period = plan.period_s
    backend.open()
    try:
        reading = backend.read(0.0)
        pipeline.begin(reading.q1_rad, reading.q2_rad)
        events.append(_event(0, period, "start", "trial started",
                             {"patient": patient, "seed": seed}))
        total = pipeline.total_ticks
        every = max(1, total // 100)
        for k in range(total):
            now = k * period
            if k:
                try:
                    reading = backend.read(now)
                except BackendError as exc:
                    reading = exc
            if isinstance(reading, BaseException):
                # the supervisor turns a failed read into its fault and zero torque
                supervisor.step(now, reading, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False, False)
            else:
                tau = pipeline.control(k, reading)
                out1, out2, fault = supervisor.step(
                    now, reading, *pipeline.rates, *tau, 0.0, 0.0, False, False
                )
                backend.write(out1, out2)
                state = State.FAULTED if fault else State.RUNNING
                log.append(pipeline.record(k, reading, now, 0.0, 0.0, (out1, out2),
                                           int(state), int(fault), with_subject=False))
            if supervisor.fault:
                status = "faulted"
                events.append(_event(k, period, "fault", supervisor.fault_message,
                                     supervisor.fault_detail))
                break
            if progress is not None and k % every == 0:
                progress(k / total)
        else:
            events.append(_event(total, period, "stop", "trial complete", {}))
    finally:
        backend.safe_state()
        backend.close()
    return _finish(plan, log.to_array(), events, status, patient, seed, started, "python",
                   handed_over, progress, load_s)


def _finish(plan, records, events, status, patient, seed, started, engine, handed_over,
            progress, load_s) -> SimulatedTrial:
    fill_subject_channels(records, plan)
    if progress is not None:
        progress(1.0)
    return SimulatedTrial(plan, records, tuple(events), status, patient, seed,
                          time.perf_counter() - started, engine, handed_over, load_s)


def save(trial: SimulatedTrial, path: Path, *, subject_code: str = "SIM") -> Analysis:
    """Analyse a simulated trial and write its file; returns the analysis."""
    params = trial.plan.parameters
    channels = {name: trial.records[name] for name in trial.records.dtype.names}
    analysis = analyse(channels, params)
    write_trial(
        path, trial.records,
        parameters=params,
        subject=SubjectInfo.from_parameters(subject_code, params),
        robot=trial.plan.robot,
        backend=f"simulator ({trial.patient}, seed {trial.seed})",
        sample_period_s=trial.plan.period_s,
        events=trial.events,
        status=trial.status,
        summary={"speed_vs_real_time": trial.speed_vs_real_time, "engine": trial.engine,
                 "exercise_start_s": analysis.exercise_start_s},
        metrics=analysis.metrics.to_dict(),
    )
    return analysis


def _event(tick: int, period: float, kind: str, message: str, values: dict) -> dict:
    return {"time_s": tick * period, "tick": tick, "kind": kind, "message": message,
            "values": values}
