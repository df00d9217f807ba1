"""Isometric strength and position sense end to end on the simulator (issue 31): the
protocol's trials (core.assessment.protocol) run headless by the battery's runner on the
realistic robot for the healthy, weak and passive virtual patients, written as trial
files with their phases as events and their figures in the metrics, ordered as the
patients are."""

import math

import h5py
import pytest

from app.assessments.runner import run_task
from app.trials.reader import read_trial
from core.assessment.figures import STRENGTH_DIRECTIONS_DEG, strength_key

KINDS = ("healthy", "weak", "passive")


@pytest.fixture(scope="module")
def strength(tmp_path_factory):
    folder = tmp_path_factory.mktemp("strength")
    return {kind: run_task("strength", kind, seed=3, folder=folder)[0] for kind in KINDS}


def test_an_arm_that_lost_selectivity_pushes_less_across_its_synergy(strength):
    """The weak arm's loss of selective joint control (device.sim.patients, selectivity):
    its pushes along the synergy keep their force, those across it lose much of it and fall
    short of the line, as a paretic arm's isometric torques out of synergy do (Dewald &
    Beer 2001). The weak kind has lost half of it by default; here against the same arm
    with its selectivity whole."""
    lost = strength["weak"].metrics
    whole = run_task("strength", "weak", seed=3, in_memory=True,
                     patient_options={"selectivity_loss": 0.0})[0].figures
    ratios = [lost[strength_key("mean", deg)] / whole[strength_key("mean", deg)]
              for deg in STRENGTH_DIRECTIONS_DEG]
    assert max(ratios) > 0.9
    assert min(ratios) < 0.7
    assert 0 < lost["strength_at_limit_count"] < whole["strength_at_limit_count"]


@pytest.fixture(scope="module")
def position(tmp_path_factory):
    folder = tmp_path_factory.mktemp("position")
    return {kind: run_task("position", kind, seed=3, folder=folder)[0] for kind in KINDS}


def test_strength_orders_the_patients(strength):
    """The healthy patient pushes up to the robot's line in every direction (its peaks are
    the line: all 8 flagged), the weak one, its selectivity half lost, only along its
    synergy (some flagged, not all) and later (a lower mean in every direction); the
    passive patient pushes nothing and reaches no line."""
    m = {kind: strength[kind].metrics for kind in KINDS}
    for kind in KINDS:
        assert strength[kind].status == "complete"
    assert m["healthy"]["strength_at_limit_count"] == 8
    assert 0 < m["weak"]["strength_at_limit_count"] < 8
    assert m["passive"]["strength_at_limit_count"] == 0
    assert m["passive"]["strength_peak_force_n"] < 0.5
    assert (m["healthy"]["strength_mean_force_n"] > m["weak"]["strength_mean_force_n"]
            > m["passive"]["strength_mean_force_n"])
    for deg in STRENGTH_DIRECTIONS_DEG:
        key = strength_key("mean", deg)
        assert m["healthy"][key] > m["weak"][key] > m["passive"][key]
        # a push held at a line of 4-6 N, or short of it across the synergy
        assert 2.5 < m["weak"][strength_key("peak", deg)] < 7.0


def test_a_strength_file_holds_every_phase_as_an_event(strength):
    trial = strength["healthy"]
    with h5py.File(trial.path, "r") as f:
        events = f["events"][:]
    cues = [e for e in events if e["kind"].decode() == "assessment_cue"]
    assert [c["message"].decode() for c in cues] == ["ready", "push", "rest"] * 8
    stored = read_trial(trial.path)
    assert stored.parameters.assessment == "strength"
    assert stored.metrics["strength_at_limit_count"] == trial.metrics["strength_at_limit_count"]


def test_position_orders_the_patients(position):
    """Healthy matches within a couple of centimetres, the weak patient (3 cm of
    proprioceptive error, a weak arm on a robot that is not massless) further off, the
    passive one not at all: every target counted, the errors NaN."""
    m = {kind: position[kind].metrics for kind in KINDS}
    for kind in KINDS:
        assert position[kind].status == "complete"
    assert m["healthy"]["position_absolute_error_m"] < 0.025
    assert m["weak"]["position_absolute_error_m"] > m["healthy"]["position_absolute_error_m"]
    assert m["weak"]["position_variable_error_m"] > m["healthy"]["position_variable_error_m"]
    assert m["healthy"]["position_not_reproduced_count"] == 0
    assert m["weak"]["position_not_reproduced_count"] == 0
    assert m["passive"]["position_not_reproduced_count"] == 12  # 4 targets, 3 rounds
    for key in ("position_absolute_error_m", "position_variable_error_m",
                "position_constant_error_m"):
        assert math.isnan(m["passive"][key])
