"""A course of headless trials with a virtual patient that adapts from trial to trial
(device.sim.learning): how its effort evolves under an assistance mode.

Each trial runs with the patient's effort at its current share of capability; after it,
the error the patient felt (the RMS distance of the hand from their own desired motion)
sets the next trial's share. Researchers use it to see whether an assistance scheme
keeps a patient working or lets them slack (bench/slacking.py prints both curves).

A course either repeats the same trial (the settings fixed, as a fixed full assistance
is) or, with `follow_proposals`, runs each trial with the proposal the console made after
the one before (app.trials.progression), as a therapist who accepts every proposal does.
The second is the assist-as-needed scheme whole: within a trial the robot gives way as
the patient leads, and between trials the exercise gets harder when it is easy. Held at
the thesis's 4 s per traversal, a transparent robot leaves a healthy patient only the
few millimetres of error its own inertia and friction make, and the adaptation model
(device.sim.learning) lets the effort settle where that error sustains it (77 % of
capability, bench/slacking.py); a faster exercise asks for more.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from app.trials.analysis import analyse, exercise_mask
from app.trials.headless import simulate
from app.trials.progression import Proposal, propose
from core.trial import TrialParameters
from device.sim.learning import TrialToTrialAdaptation, intent_error_m
from device.sim.patient_parameters import DEFAULT_EFFORT


@dataclass(frozen=True, slots=True)
class CourseTrial:
    """One trial of a course: the share of capability used, the effort given to the
    virtual patient, the error the patient felt (m), who did the work, the share of the
    exercise the patient led (%), and the settings the trial ran with (assistance level
    0–1, time per traversal in s, tolerance in rad)."""

    share: float
    effort: float
    felt_error_m: float
    robot_work_J: float
    patient_work_J: float
    robot_work_share: float
    status: str
    led_pct: float
    assistance_level: float
    duration_s: float
    tolerance_rad: float


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
               follow_proposals: bool = False,
               patient_options: Mapping[str, object] | None = None) -> list[CourseTrial]:
    """`trials` headless trials of `parameters` with an adapting `patient` (a kind that
    makes an effort: not "passive"), starting at `start_share` of its capability; with
    `follow_proposals` each trial after the first takes the console's proposal made after
    the one before (the module notes). `patient_options` are the patient's other options
    (device.sim.patients.make_patient; its effort is the course's)."""
    rule = adaptation or TrialToTrialAdaptation()
    capability = DEFAULT_EFFORT.get(patient, 1.0)
    share = float(start_share)
    course: list[CourseTrial] = []
    proposal: Proposal | None = None  # the one this trial runs with: it sets the next step
    for _ in range(trials):
        effort = share * capability
        trial = simulate(parameters, patient=patient, seed=seed, plant=plant,
                         engine=engine,
                         patient_options={**(patient_options or {}), "effort": effort})
        error = felt_error(trial.records, parameters)
        channels = {name: trial.records[name] for name in trial.records.dtype.names}
        m = analyse(channels, parameters).metrics
        course.append(CourseTrial(share, effort, error, m.robot_work_J, m.patient_work_J,
                                  m.robot_work_share, trial.status, m.led_pct,
                                  parameters.assistance_level, parameters.duration_s,
                                  parameters.tolerance_rad))
        share = rule.next_share(share, error)
        if follow_proposals:
            proposal = propose(parameters, m.to_dict(), trial.status, proposal)
            parameters = proposal.applied_to(parameters)
    return course
