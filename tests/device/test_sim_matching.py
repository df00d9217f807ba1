"""The virtual patient matching a position (device.sim.holdtasks, position sense): a point
it remembers beyond its arm's reach is matched as far as the arm goes, not refused as a
path out of reach (the README's example patient, 0.58 m of arm 0.56 m from the farthest
target, could not run the battery's position sense on about half the weak seeds)."""

import numpy as np

from core.assessment.protocol import protocol
from core.trial import TrialParameters
from device.sim.holdtasks import HEALTHY_SD_M, behaviour
from device.sim.patients import make_patient

# the README's `rehab patients add` example: 0.30 + 0.28 m of arm, shoulder (-0.12, 0.73)
EXAMPLE = TrialParameters().replace(body_mass_kg=70.0, upper_arm_m=0.30, forearm_m=0.28,
                                    shoulder_m=(-0.12, 0.73))
TRIAL = protocol("position").parameters(EXAMPLE, 0)


def _beyond(seeds, sd_m):
    """The seeds whose remembered points leave the arm's reach, drawn without the arm."""
    shoulder, reach = np.array(EXAMPLE.shoulder_m), 0.30 + 0.28
    out = []
    for seed in seeds:
        drawn = np.array(behaviour(TRIAL.trajectory(), 1.0, 40.0, sd_m, seed).remembered_m)
        if (np.hypot(*(drawn - shoulder).T) > reach).any():
            out.append(seed)
    return out


def test_a_point_remembered_beyond_reach_is_matched_at_the_arms_reach():
    arm = TRIAL.arm()
    far = _beyond(range(40), 0.03)
    assert far, "no seed draws a point beyond reach: the test lost its case"
    for seed in far[:3]:
        patient = make_patient("weak", arm, TRIAL.trajectory(), seed=seed)
        matched = np.array(patient.task.remembered_m)
        distance = np.hypot(*(matched - np.array(EXAMPLE.shoulder_m)).T)
        assert (distance < arm.reach_max_m).all()
        assert distance.max() > arm.reach_max_m - 0.002  # as far as it goes, no farther in


def test_points_within_reach_are_matched_as_drawn():
    arm = TRIAL.arm()
    near = [s for s in range(10) if s not in _beyond(range(10), HEALTHY_SD_M)]
    for seed in near[:3]:
        drawn = behaviour(TRIAL.trajectory(), 1.0, 40.0, HEALTHY_SD_M, seed).remembered_m
        patient = make_patient("healthy", arm, TRIAL.trajectory(), seed=seed)
        assert patient.task.remembered_m == drawn
