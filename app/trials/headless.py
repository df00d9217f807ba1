"""A whole trial on the simulator without a screen or a real-time loop, as fast as it runs.

The same per-tick pipeline, safety supervisor and trial file as a live trial; only the
pacing differs (simulated time advances tick by tick instead of waiting for the clock).
Researchers use it to try parameters and virtual patients; the tests use it end to end.

The ticks are device.loop.engine's `run_ticks`: the same kernels as the live loop's
tick, with the simulator's physics, run compiled by numba ("compiled", the default:
about a thousand times real time) or interpreted ("python": the reference, the same
samples bit for bit, slower).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.trials.analysis import Analysis, analyse
from core.control.guidance import GuidanceGains
from core.errors import ParameterError
from core.robot import RobotModel
from core.trial import TrialParameters
from device.compiled.warmup import load_kernels
from device.loop.engine import run_trial
from device.loop.pipeline import TickPipeline, TrialPlan, assistance_group
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
    load_s: float = 0.0
    """Time spent loading the compiled kernels before the run (once per process)."""
    plant: dict | None = None
    """The simulated robot's parameters (device.sim.plant.Plant.describe)."""
    guidance: GuidanceGains | None = None
    """The as-needed mode's gains (None in the thesis mode)."""
    feedforward_N: np.ndarray | None = None
    """The as-needed mode's learned feedforward per repetition and bin
    (TickPipeline.feedforward_history)."""

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
    plant: str = "realistic",
    guidance: GuidanceGains | None = None,
) -> SimulatedTrial:
    """Run a trial on the simulator with a virtual patient of kind `patient`.

    Refuses unreachable or absurd parameters before anything runs (TrialPlan.build).
    The safety supervisor watches every tick as in a live trial; a fault (or a
    backend failure, which it turns into one) ends the trial as "faulted" with the
    cause as an event, and the samples up to it are kept.

    `engine` is one of ENGINES: "compiled" runs the ticks' kernels compiled (numba),
    "python" interpreted (the reference: the same code, the same samples bit for bit,
    a few hundred times slower), "auto" compiled. `plant` is the simulated robot
    (device.sim.plant.PLANTS): "realistic", its own parameters drawn by the seed around
    the controller's model, or "ideal", the model itself. `guidance` sets the as-needed
    mode's gains (core.control.guidance; its defaults otherwise).
    """
    if engine not in ENGINES:
        raise ParameterError("engine", engine, "one of " + ", ".join(ENGINES))
    plan = TrialPlan.build(parameters, robot)
    compiled = engine != "python"
    # load the compiled kernels before anything is timed (from the cache: a fraction of a s)
    load_s = load_kernels(("headless",)) if compiled else 0.0
    backend = SimulatorBackend.from_trial(
        parameters, patient, seed=seed, robot=plan.robot, patient_options=patient_options,
        compiled=compiled, plant=plant,
    )
    pipeline = TickPipeline(plan, compiled=compiled, guidance=guidance)
    supervisor = SafetySupervisor(plan.robot)
    started = time.perf_counter()
    outcome = run_trial(backend, pipeline, supervisor, progress)
    period = plan.period_s
    events = [_event(0, period, "start", "trial started", {"patient": patient, "seed": seed})]
    if outcome.status == "complete":
        events.append(_event(len(outcome.records), period, "stop", "trial complete", {}))
    else:
        events.append(_event(outcome.fault_tick, period, "fault", outcome.fault_message,
                             outcome.fault_detail))
    records = outcome.records
    if progress is not None:
        progress(1.0)
    return SimulatedTrial(plan, records, tuple(events), outcome.status, patient, seed,
                          time.perf_counter() - started, "compiled" if compiled else "python",
                          load_s, backend.plant.describe(), pipeline.guidance,
                          pipeline.feedforward_history)


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
                 "exercise_start_s": analysis.exercise_start_s,
                 **_plant_summary(trial.plant)},
        metrics=analysis.metrics.to_dict(),
        assistance=assistance_group(params, trial.guidance, trial.feedforward_N),
    )
    return analysis


def _event(tick: int, period: float, kind: str, message: str, values: dict) -> dict:
    return {"time_s": tick * period, "tick": tick, "kind": kind, "message": message,
            "values": values}


def _plant_summary(plant: dict | None) -> dict:
    """The simulated plant as the summary's scalars: its kind, and every parameter as
    JSON (device.sim.plant.Plant.describe)."""
    if plant is None:
        return {}
    import json

    return {"plant": plant["kind"], "plant_parameters": json.dumps(plant)}
