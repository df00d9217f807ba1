"""The virtual healthy population (device.sim.population): deterministic for a seed, bodies
in Winter's proportions over realistic ranges, the age, sex and handedness effects and the
learning the module notes describe, and subjects the simulator accepts."""

from __future__ import annotations

import itertools
import math
from dataclasses import astuple

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.errors import ParameterError
from core.trial import THESIS_SUBJECT
from device.sim.patients import make_patient
from device.sim.population import (
    AGE_RANGE_YEARS,
    GRIP_FRACTION,
    GUIDED_IMPEDANCE_SCALE,
    WINTER_FOREARM,
    WINTER_HAND,
    WINTER_UPPER_ARM,
    draw_population,
    draw_subject,
)


@pytest.fixture(scope="module")
def crowd():
    return draw_population(600, 11)


def test_a_seed_gives_the_same_subjects_and_a_subject_does_not_depend_on_the_size():
    assert draw_population(30, 4) == draw_population(30, 4)
    assert draw_population(5, 4) == draw_population(30, 4)[:5]
    assert draw_subject(4, 17) == draw_population(30, 4)[17]
    other = draw_population(30, 5)
    assert all(astuple(a)[2:] != astuple(b)[2:] for a, b in zip(draw_population(30, 4), other,
                                                                strict=True))


def test_bodies_follow_winter_over_realistic_ranges(crowd):
    height = np.array([s.height_m for s in crowd])
    upper = np.array([s.upper_arm_m for s in crowd]) / height
    forearm = np.array([s.forearm_m for s in crowd]) / height
    assert np.median(upper) == pytest.approx(WINTER_UPPER_ARM, rel=0.02)
    assert np.median(forearm) == pytest.approx(WINTER_FOREARM + GRIP_FRACTION * WINTER_HAND,
                                               rel=0.02)
    men = height[[s.sex == "male" for s in crowd]]
    women = height[[s.sex == "female" for s in crowd]]
    assert 1.70 < men.mean() < 1.82
    assert 1.57 < women.mean() < 1.69
    assert height.min() > 1.4
    assert height.max() < 2.05
    bmi = np.array([s.body_mass_kg / s.height_m ** 2 for s in crowd])
    assert bmi.min() >= 18.0
    assert bmi.max() <= 40.0
    ages = np.array([s.age_years for s in crowd])
    assert AGE_RANGE_YEARS[0] <= ages.min()
    assert ages.max() <= AGE_RANGE_YEARS[1]
    assert ages.max() - ages.min() > 55.0
    left = sum(s.handedness == "left" for s in crowd)
    assert 30 <= left <= 95  # 10 % of 600: binomial 60 ± 7.3, so ±4 SD
    assert 240 <= len(men) <= 360


def test_age_and_sex_change_strength_reaction_and_speed_as_described(crowd):
    ages = np.array([s.age_years for s in crowd])
    for name, sign in (("reaction_time_s", 1), ("speed_scale", -1), ("variability", 1),
                       ("drive_N", -1)):
        values = np.array([getattr(s, name) for s in crowd])
        assert sign * np.corrcoef(ages, values)[0, 1] > 0.2, name
    young_men = [s.strength for s in crowd if s.sex == "male" and s.age_years < 50]
    young_women = [s.strength for s in crowd if s.sex == "female" and s.age_years < 50]
    assert set(young_men) == {1.0}
    assert set(young_women) == {0.6}
    old = [s for s in crowd if s.sex == "male" and s.age_years > 80]
    assert all(s.strength == pytest.approx(1.0 - 0.01 * (s.age_years - 50)) for s in old)


def test_learning_makes_the_first_trials_slower_more_variable_and_weaker():
    s = draw_subject(0, 3)
    cv = [s.variability_at(n, s.handedness) for n in range(12)]
    rt = [s.reaction_time_at(n) for n in range(12)]
    drive = [s.patient_options(n, guided=True)["drive_N"] for n in range(12)]
    assert all(a > b for a, b in itertools.pairwise(cv))
    assert all(a > b for a, b in itertools.pairwise(rt))
    assert all(a < b for a, b in itertools.pairwise(drive))
    assert cv[0] == pytest.approx(1.5 * s.variability)
    assert s.patient_options(1_000, guided=True)["drive_N"] == pytest.approx(s.drive_N)
    with pytest.raises(ParameterError, match="trial"):
        s.learned(-1)


def test_the_non_dominant_arm_is_weaker_and_more_variable():
    s = next(s for s in draw_population(50, 2) if s.handedness == "right")
    right = s.patient_options(side="right", guided=True)
    left = s.patient_options(side="left", guided=True)
    assert left["drive_N"] == pytest.approx(0.93 * right["drive_N"])
    assert left["variability"] == pytest.approx(1.15 * right["variability"])
    assert left["stiffness_Nm_rad"][0] < right["stiffness_Nm_rad"][0]


def test_a_subject_on_their_own_holds_the_arm_at_their_reaching_impedance():
    """Guided round the thesis's D a subject relaxes to the calibrated quarter of the
    reaching impedance; in the battery (the robot transparent, or the subject's own plan)
    the same subject holds their own reaching impedance: four times it, the rest alike."""
    s = draw_subject(0, 4)
    guided, own = s.patient_options(guided=True), s.patient_options(guided=False)
    for key in ("stiffness_Nm_rad", "damping_Nms_rad"):
        assert own[key] == pytest.approx(tuple(v / GUIDED_IMPEDANCE_SCALE
                                               for v in guided[key]))
    assert {k: v for k, v in own.items() if k not in ("stiffness_Nm_rad", "damping_Nms_rad")
            } == {k: v for k, v in guided.items()
                  if k not in ("stiffness_Nm_rad", "damping_Nms_rad")}


def test_trial_seeds_are_the_subjects_own_and_differ_between_trials():
    a, b = draw_subject(9, 0), draw_subject(9, 1)
    seeds = {a.trial_seed(n) for n in range(20)} | {b.trial_seed(n) for n in range(20)}
    assert len(seeds) == 40
    assert a.trial_seed(3) == draw_population(2, 9)[0].trial_seed(3)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2 ** 32), index=st.integers(0, 5000),
       trial=st.integers(0, 50), side=st.sampled_from(("right", "left")))
def test_every_subject_is_a_patient_the_simulator_accepts(seed, index, trial, side):
    s = draw_subject(seed, index)
    params = s.trial_parameters(THESIS_SUBJECT, side)
    assert (params.body_mass_kg, params.upper_arm_m, params.forearm_m, params.side) == (
        s.body_mass_kg, s.upper_arm_m, s.forearm_m, side)
    options = s.patient_options(trial, side, guided=trial % 2 == 0)
    assert 0.0 < options["variability"] <= 1.0
    # the options and the body are within what make_patient and the arm accept
    arm = params.replace(side="right", shoulder_m=THESIS_SUBJECT.shoulder_m).arm()
    assert math.isfinite(arm.upper_arm_m)
    cov = s.covariates(side)
    assert cov["tested_side"] == side
    assert cov["sex"] in ("female", "male")
    assert s.code.startswith(f"SIM{seed}-")
    make_patient("healthy", THESIS_SUBJECT.arm(), THESIS_SUBJECT.trajectory(),
                 seed=s.trial_seed(trial), **options)


@pytest.mark.parametrize(("n", "seed"), [(0, 0), (-3, 0), (True, 0), (2.5, 0), (10, -1),
                                     (10, 1.5), (10, True)])
def test_bad_sizes_and_seeds_are_refused_by_name(n, seed):
    with pytest.raises(ParameterError, match=r"subjects|seed"):
        draw_population(n, seed)
