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

from app.assessments.events import cue_events
from app.errors import AppError
from app.trials.analysis import Analysis, analyse, analyse_stored
from core.control.guidance import GuidanceGains
from core.errors import ParameterError
from core.robot import RobotModel
from core.trial import TrialParameters
from core.trial_check import check_trial
from device.compiled.warmup import load_kernels
from device.loop.engine import Feed, Sink, run_trial
from device.loop.pipeline import (
    PERIOD_S,
    TickPipeline,
    TrialPlan,
    assistance_group,
    has_compiled_form,
    learned_controller,
    learned_model_refusal,
)
from device.recording.trialfile import SubjectInfo, TrialFileWriter
from device.safety.supervisor import SafetySupervisor
from device.sim.plant import plant_summary
from device.sim.seeds import ROBOT_SEED, draw_seed
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
    n_ticks: int = -1
    """How many ticks ran (the records' length, or what went to the file when the run
    streamed them: then `records` is empty)."""
    estimate: dict | None = None
    """With a force estimate (app.emg.feed), its entries for the /assistance group."""

    @property
    def simulated_s(self) -> float:
        n = len(self.records) if self.n_ticks < 0 else self.n_ticks
        return n * self.plan.period_s

    @property
    def speed_vs_real_time(self) -> float:
        return self.simulated_s / self.elapsed_s if self.elapsed_s > 0 else float("inf")


def simulate(
    parameters: TrialParameters,
    *,
    patient: str = "healthy",
    seed: int | None = 0,
    robot: RobotModel | None = None,
    progress: Progress | None = None,
    patient_options: dict | None = None,
    engine: str = "auto",
    plant: str = "realistic",
    guidance: GuidanceGains | None = None,
    sink: Sink | None = None,
    model=None,
    feed: Feed | None = None,
    robot_seed: int = ROBOT_SEED,
) -> SimulatedTrial:
    """Run a trial on the simulator with a virtual patient of kind `patient`.

    Refuses unreachable or absurd parameters before anything runs (TrialPlan.build).
    The safety supervisor watches every tick as in a live trial; a fault (or a
    backend failure, which it turns into one) ends the trial as "faulted" with the
    cause as an event, and the samples up to it are kept.

    `engine` is one of ENGINES: "compiled" runs the ticks' kernels compiled (numba),
    "python" interpreted (the reference: the same code, the same samples bit for bit,
    a few hundred times slower), "auto" compiled. `plant` is the simulated robot
    (device.sim.plant.PLANTS): "realistic", its own parameters drawn by `robot_seed`
    around the controller's model (the same robot whatever `seed`), or "ideal", the model
    itself. `guidance` sets the as-needed
    mode's gains (core.control.guidance; its defaults otherwise). With a `sink`, the
    records go to it block by block (device.loop.engine.run_trial) and the result holds
    none: `simulate_to_file` uses it so a long trial's memory stays flat. `model` is the
    learned model the parameters name (`learned_model`; app.learning.library checks it):
    the computed-torque PID runs on it, compiled for an FNN or a DeLaN. A `feed`
    (app.emg.feed) gives the assistance its estimate of the patient's force between
    ticks, for parameters that name one (`force_estimate`). `seed` None draws a new one
    (device.sim.seeds.draw_seed; the result's `seed` says which).
    """
    if seed is None:
        seed = draw_seed()
    if engine not in ENGINES:
        raise ParameterError("engine", engine, "one of " + ", ".join(ENGINES))
    plan = TrialPlan.build(parameters, robot)
    refused = learned_model_refusal(parameters, model)
    if refused:
        raise ParameterError("model", getattr(model, "name", None), "the model the trial "
                             "names", refused)
    controller = None if model is None else learned_controller(model, plan)
    # a learned model without a compiled form (a GRU) runs interpreted through its step
    compiled = engine != "python" and (model is None or has_compiled_form(model))
    # load the compiled kernels before anything is timed (from the cache: a fraction of a s)
    load_s = load_kernels(("headless",)) if compiled else 0.0
    backend = SimulatorBackend.from_trial(
        parameters, patient, seed=seed, robot=plan.robot, patient_options=patient_options,
        compiled=compiled, plant=plant, robot_seed=robot_seed,
    )
    pipeline = TickPipeline(plan, compiled=compiled, guidance=guidance, controller=controller)
    if bool(parameters.force_estimate) != (feed is not None):
        raise ParameterError("feed", type(feed).__name__, "a feed of the force estimate "
                             "exactly when the parameters name one (force_estimate)")
    if feed is not None:
        feed.attach(pipeline)
    supervisor = SafetySupervisor(plan.robot)
    started = time.perf_counter()
    outcome = run_trial(backend, pipeline, supervisor, progress, sink, feed)
    period = plan.period_s
    events = [_event(0, period, "start", "trial started", {"patient": patient, "seed": seed,
                                                            "robot_seed": robot_seed})]
    # an assessment's cues, from the exercise's first tick (after the approach)
    events += cue_events(parameters, pipeline.n_rows - plan.exercise_ticks, period,
                         outcome.n_ticks)
    if outcome.status == "complete":
        events.append(_event(outcome.n_ticks, period, "stop", "trial complete", {}))
    else:
        events.append(_event(outcome.fault_tick, period, "fault", outcome.fault_message,
                             outcome.fault_detail))
    records = outcome.records
    if progress is not None:
        progress(1.0)
    return SimulatedTrial(plan, records, tuple(events), outcome.status, patient, seed,
                          time.perf_counter() - started, "compiled" if compiled else "python",
                          load_s, backend.plant.describe(), pipeline.guidance,
                          pipeline.feedforward_history, outcome.n_ticks,
                          None if feed is None else feed.assistance_entries())


def save(trial: SimulatedTrial, path: Path, *, subject_code: str = "SIM") -> Analysis:
    """Analyse a simulated trial held in memory and write its file; returns the analysis
    (refuses, writing nothing, when the trial has too little exercise for its figures)."""
    params = trial.plan.parameters
    channels = {name: trial.records[name] for name in trial.records.dtype.names}
    analysis = analyse(channels, params, trial.plan.robot)
    writer = _writer(path, params, trial.plan.robot, trial.plan.period_s, trial.patient,
                     trial.seed, subject_code)
    try:
        writer.append(trial.records)
    except BaseException:
        writer.close("recording_lost")
        raise
    _finish(writer, trial, analysis)
    return analysis


def simulate_to_file(
    parameters: TrialParameters,
    path: Path,
    *,
    subject_code: str = "SIM",
    patient: str = "healthy",
    seed: int | None = 0,
    robot: RobotModel | None = None,
    progress: Progress | None = None,
    **options,
) -> tuple[SimulatedTrial, Analysis | None, str]:
    """`simulate` straight into the trial file at `path`, block by block, so memory stays
    flat whatever the trial's length (a 100 × 120 s trial is 6 million ticks); the metrics
    come from the channels they need, read back from the file a block at a time before
    it is closed (app.trials.analysis.analyse_stored: the figures of `analyse` to
    rounding, without Fig. 3.9's intervals, which the file does not keep).

    Returns the trial (without its records), its analysis and "" or, when the trial had
    too little exercise for its figures (a fault in the approach), None and why: the
    file is kept with its samples, events and status either way. A failure to write
    closes the file as "recording_lost" and raises. `options` are `simulate`'s.
    """
    robot = robot or RobotModel()
    check_trial(parameters, robot).require_ok()  # refused before a file exists
    seed = draw_seed() if seed is None else seed  # the file names the one it ran
    writer = _writer(path, parameters, robot, PERIOD_S, patient, seed, subject_code)
    try:
        trial = simulate(parameters, patient=patient, seed=seed, robot=robot,
                         progress=progress, sink=writer.append, **options)
        writer.flush_for_reading()
        names = writer.channel_names()
    except BaseException:
        writer.close("recording_lost")
        raise
    try:
        analysis, problem = analyse_stored(writer.read_stretch, trial.n_ticks, names,
                                           parameters, robot=robot), ""
    except AppError as exc:
        analysis, problem = None, str(exc)
    except BaseException:
        writer.close("recording_lost")
        raise
    _finish(writer, trial, analysis)
    feed = options.get("feed")
    if feed is not None:
        feed.store_emg(path)
    return trial, analysis, problem


def _writer(path: Path, parameters: TrialParameters, robot: RobotModel, period_s: float,
            patient: str, seed: int, subject_code: str) -> TrialFileWriter:
    return TrialFileWriter(
        path, parameters=parameters,
        subject=SubjectInfo.from_parameters(subject_code, parameters), robot=robot,
        backend=f"simulator ({patient}, seed {seed})", sample_period_s=period_s, live=False,
        flush_interval_s=None,
    )


def _finish(writer: TrialFileWriter, trial: SimulatedTrial, analysis: Analysis | None) -> None:
    """The trial's events, status, summary, metrics and assistance into its file."""
    try:
        for event in trial.events:
            writer.add_event(event["time_s"], event["tick"], event["kind"], event["message"],
                             event.get("values"))
    except BaseException:
        writer.close("recording_lost")
        raise
    summary = {"speed_vs_real_time": trial.speed_vs_real_time, "engine": trial.engine,
               **plant_summary(trial.plant)}
    if analysis is not None:
        summary["exercise_start_s"] = analysis.exercise_start_s
    writer.close(trial.status, summary,
                 analysis.to_metrics() if analysis is not None else None,
                 {**assistance_group(trial.plan.parameters, trial.guidance, trial.feedforward_N),
                  **(trial.estimate or {})})


def _event(tick: int, period: float, kind: str, message: str, values: dict) -> dict:
    return {"time_s": tick * period, "tick": tick, "kind": kind, "message": message,
            "values": values}

