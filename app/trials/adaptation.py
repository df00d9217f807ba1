"""A course of headless trials with a virtual patient that adapts from trial to trial
(device.sim.learning): how its effort evolves under an assistance mode.

Each trial runs with the patient's effort at its current share of capability; after it,
the error the patient felt (the RMS distance of the hand from their own desired motion)
sets the next trial's share. Researchers use it to see whether an assistance scheme
keeps a patient working or lets them slack (bench/slacking.py prints both curves).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.trials.analysis import analyse, exercise_mask
from app.trials.headless import simulate
from core.trial import TrialParameters
from device.sim.learning import TrialToTrialAdaptation, intent_error_m
from device.sim.patients import DEFAULT_EFFORT


@dataclass(frozen=True, slots=True)
class CourseTrial:
    """One trial of a course: the share of capability used, the effort given to the
    virtual patient, the error the patient felt (m), and who did the work."""

    share: float
    effort: float
    felt_error_m: float
    robot_work_J: float
    patient_work_J: float
    robot_work_share: float
    status: str


def felt_error(records, parameters: TrialParameters) -> float:
    """The RMS distance of the hand from the patient's own desired motion over the
    exercise, the patient's clock starting at the exercise's first sample."""
    mask = exercise_mask({"phase": records["phase"]})
    t = records["time"][mask]
    if t.size == 0:
        return float("nan")
    trajectory = parameters.trajectory()
    patient_t = np.minimum(t - t[0], trajectory.total_duration_s)
    intended = trajectory.sample(patient_t).position_m
    return intent_error_m(records["position"][mask], intended)


def run_course(parameters: TrialParameters, *, patient: str = "weak", trials: int = 20,
               start_share: float = 1.0, adaptation: TrialToTrialAdaptation | None = None,
               plant: str = "realistic", seed: int = 0, engine: str = "auto",
               ) -> list[CourseTrial]:
    """`trials` headless trials of `parameters` with an adapting `patient` (a kind that
    makes an effort: not "passive"), starting at `start_share` of its capability."""
    rule = adaptation or TrialToTrialAdaptation()
    capability = DEFAULT_EFFORT.get(patient, 1.0)
    share = float(start_share)
    course: list[CourseTrial] = []
    for _ in range(trials):
        effort = share * capability
        trial = simulate(parameters, patient=patient, seed=seed, plant=plant,
                         engine=engine, patient_options={"effort": effort})
        error = felt_error(trial.records, parameters)
        channels = {name: trial.records[name] for name in trial.records.dtype.names}
        m = analyse(channels, parameters).metrics
        course.append(CourseTrial(share, effort, error, m.robot_work_J, m.patient_work_J,
                                  m.robot_work_share, trial.status))
        share = rule.next_share(share, error)
    return course
