"""Running an assessment task, or the whole battery, on the simulator without a screen.

Each of a task's trials (core.assessment.protocol: its trial count) is an ordinary
headless trial (app.trials.headless.simulate_to_file) of the task's parameters built on the
patient's: its file holds the samples, the cues as timed events and, in its metrics, the
task's figures beside the movement's (app.trials.analysis adds them to every assessment
trial). Registered for a patient, each trial begins and ends with its registry row as
`rehab run`'s does (app.trials.registered, app.trials.finalize), so the registry's metrics
hold the same figures. Trial k of a task runs with seed `seed + k`.

With `in_memory` (a virtual population's visits, app.population.norms: thousands of
trials nobody opens again) no file is written: the trial runs in memory and only its task
figures are computed, from its whole arrays (app.assessments.figures.assessment_figures,
the function a trial file's figures come from a block at a time). Writing, sealing,
verifying and reading back each file and the exercise's figures were three quarters of a
visit's time (py-spy over a population build, 2026-12-03).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, replace
from pathlib import Path

from app.errors import AppError
from app.records.store import RecordStore
from core.assessment import TASKS, task_figures
from core.assessment.protocol import protocol
from core.errors import ParameterError
from core.trial import TrialParameters


@dataclass(frozen=True, slots=True)
class TaskTrial:
    """One trial of a task as it ran."""

    task: str
    index: int
    label: str
    """The trial's label in its protocol ("clockwise", …; "" for a task of one trial)."""
    parameters: TrialParameters
    path: Path | None
    """The trial's file (None for a trial run `in_memory`)."""
    status: str
    seed: int
    metrics: dict[str, float]
    """Everything the trial's file and registry row hold as metrics."""
    notes: tuple[str, ...]
    trial_id: int | None
    simulated_s: float
    elapsed_s: float
    """Wall time of the whole trial: building, running, measuring and writing it."""
    session_number: int | None = None
    trial_number: int | None = None
    """The patient's session and trial numbers the registry gave it (None without one)."""

    @property
    def figures(self) -> dict[str, float]:
        """The task's own figures (core.assessment.FIGURES of this task) among the metrics."""
        keys = {spec.key for spec in task_figures(self.task)}
        return {key: value for key, value in self.metrics.items() if key in keys}


Progress = Callable[[str], None]


def run_task(task: str, patient: str = "healthy", base: TrialParameters | None = None,
             seed: int = 0, *, registry: RecordStore | None = None, code: str = "",
             folder: Path | None = None, patient_options: dict | None = None,
             plant: str = "realistic", engine: str = "auto",
             progress: Progress | None = None, in_memory: bool = False,
             session_number: int | None = None) -> tuple[TaskTrial, ...]:
    """Run every trial of `task` (core.assessment.TASKS) with the virtual `patient` on the
    table of `base` (THESIS_SUBJECT's by default).

    With `registry` and `code` the trials are registered for that patient, whose body
    sizes replace the base's, and written in the data folder; else they are written in
    `folder` as `<task>_<k>_<patient>_seed<seed>.h5`, refused when one exists; with
    `in_memory` (and neither) none is written (the module notes); `session_number`, the
    registered trials' session (None: today's goes on; the next number opens it). Refuses
    a task, seed or robot mode that cannot run, in one line, before any file exists."""
    spec = protocol(task)
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ParameterError("seed", seed, "a whole number from 0")
    base = base or TrialParameters()
    if in_memory and (registry is not None or folder is not None):
        raise AppError("a task run in memory writes no file: give no registry nor folder")
    if registry is not None:
        if not code:
            raise AppError("a registered assessment needs the patient's code")
        base = base.replace(**registry.patient(code).trial_overrides())
    elif folder is None and not in_memory:
        raise AppError("give a folder for the trial files or a registry and a patient's code")
    plans = [spec.parameters(base, index) for index in range(spec.trial_count)]
    out = []
    for index, parameters in enumerate(plans):
        if progress is not None:
            progress(f"{spec.name}: trial {index + 1} of {spec.trial_count}"
                     + (f" ({spec.trials[index]})" if spec.trials[index] else ""))
        out.append(_one(task, index, spec.trials[index], parameters, patient, seed + index,
                        registry, code, folder, patient_options, plant, engine,
                        session_number))
    if task == "circle":
        out = _circle_task(out, registry)
    return tuple(out)


def _circle_task(trials: list[TaskTrial], registry: RecordStore | None) -> list[TaskTrial]:
    """Both circle trials get the task's figures (each way's and their mean,
    app.assessments.figures.circle_task) beside their own, in the file and the registry;
    left as they are when either trial has no figures (a fault before its circle)."""
    from app.assessments.figures import circle_task
    from device.recording.trialfile import write_metrics

    cw, ccw = trials
    try:
        combined = circle_task(cw.metrics, ccw.metrics)
    except KeyError:
        return trials
    from app.trials.rewrite import rewriting

    done = []
    for trial in trials:
        metrics = {**trial.metrics, **combined}
        registered = registry is not None and trial.trial_id is not None
        # a registered trial's file is written after its end: its checksum follows
        with (rewriting(registry, trial.trial_id, "the circle task's figures")
              if registered else contextlib.nullcontext()):
            if trial.path is not None:
                write_metrics(trial.path, metrics)
        if registered:
            registry.update_metrics(trial.trial_id, combined)
        done.append(replace(trial, metrics=metrics))
    return done


def run_battery(patient: str = "healthy", base: TrialParameters | None = None, seed: int = 0,
                *, tasks: Iterable[str] = TASKS, **options) -> dict[str, tuple[TaskTrial, ...]]:
    """`run_task` for each of `tasks` (the whole battery by default), in the battery's
    order; task i's trials use seeds from `seed + 10·i`."""
    chosen = tuple(tasks)
    for task in chosen:
        protocol(task)  # every task refused before the first runs
    return {task: run_task(task, patient, base, seed + 10 * TASKS.index(task), **options)
            for task in TASKS if task in chosen}


def _one(task: str, index: int, label: str, parameters: TrialParameters, patient: str,
         seed: int, registry: RecordStore | None, code: str, folder: Path | None,
         patient_options: dict | None, plant: str, engine: str,
         session_number: int | None = None) -> TaskTrial:
    from app.trials.headless import simulate_to_file

    started = time.perf_counter()
    run = {"patient": patient, "seed": seed, "plant": plant, "engine": engine,
           "patient_options": patient_options}
    if registry is None and folder is None:
        return _in_memory(task, index, label, parameters, run, started)
    if registry is None:
        assert folder is not None
        path = Path(folder) / f"{task}_{index}_{patient}_seed{seed}.h5"
        if path.exists():
            raise AppError(f"{path} already exists: give another folder or seed")
        trial, analysis, problem = simulate_to_file(parameters, path, **run)
        trial_id = numbers = None
        notes = [problem] if problem else []
    else:
        from app.trials.finalize import finalize_trial
        from app.trials.registered import registered_trial

        with registered_trial(registry, code, parameters,
                              backend=f"simulator ({patient}, seed {seed})",
                              patient_kind=patient, session_number=session_number) as begun:
            path = begun.path
            trial, analysis, problem = simulate_to_file(parameters, path,
                                                        subject_code=code, **run)
        done = finalize_trial(registry, begun.trial_id, trial.status, analysis=analysis)
        trial_id = begun.trial_id
        numbers = (begun.session_number, begun.trial_number)
        notes = list(done.notes) + ([problem] if problem else [])
    if analysis is not None and registry is None:
        notes.extend(analysis.notes)
    metrics = analysis.to_metrics() if analysis is not None else {}
    return TaskTrial(task, index, label, parameters, path, trial.status, seed, metrics,
                     tuple(notes), trial_id, trial.simulated_s, time.perf_counter() - started,
                     *(numbers or (None, None)))


def _in_memory(task: str, index: int, label: str, parameters: TrialParameters, run: dict,
               started: float) -> TaskTrial:
    """A task's trial run in memory: its task figures only, no file (the module notes)."""
    from app.assessments.figures import assessment_figures
    from app.trials.analysis import MIN_EXERCISE, exercise_mask, too_little_exercise
    from app.trials.headless import simulate

    trial = simulate(parameters, **run)
    channels = {name: trial.records[name] for name in trial.records.dtype.names}
    mask = exercise_mask(channels)
    n_exercise = int(mask.sum())
    if n_exercise < MIN_EXERCISE:  # a fault in the approach: no figures, as on file
        figures, notes = {}, (too_little_exercise(n_exercise),)
    else:
        figures, notes = assessment_figures(channels, parameters, mask)
    return TaskTrial(task, index, label, parameters, None, trial.status, run["seed"],
                     dict(figures), tuple(notes), None, trial.simulated_s,
                     time.perf_counter() - started)
