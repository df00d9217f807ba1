"""Circle drawing (both ways) and active range end to end on the simulator for the healthy,
weak and passive virtual patients: the figures in the files and the task's combined figures
order them as expected."""

import math

import pytest

from app.assessments.runner import run_task
from app.trials.reader import read_trial
from core.assessment import task_figures

KINDS = ("healthy", "weak", "passive")


@pytest.fixture(scope="module")
def circles(tmp_path_factory):
    folder = tmp_path_factory.mktemp("circle")
    return {kind: run_task("circle", kind, seed=7, folder=folder) for kind in KINDS}


def test_an_arm_in_synergy_draws_a_flatter_circle_with_its_joints_together():
    """The virtual arm's flexion synergy (device.sim.patients, option `synergy`): the
    weak patient's circle flattens and its joints lose their independence."""
    apart = run_task("circle", "weak", seed=7, in_memory=True)[0].figures
    together = run_task("circle", "weak", seed=7, in_memory=True,
                        patient_options={"synergy": 0.3})[0].figures
    assert apart["circle_ratio"] - together["circle_ratio"] > 0.1
    assert together["circle_joint_independence"] < apart["circle_joint_independence"]


def test_an_arm_that_lost_selectivity_draws_a_flatter_circle_than_the_healthy_one(circles):
    """The weak arm's loss of selective joint control (device.sim.patients, selectivity):
    without it the weak patient, slower, draws a rounder circle than the healthy one; with
    it both its circle ratio and its joint independence fall under the healthy patient's
    (docs/assessments.md, The virtual patients' circles)."""
    healthy = circles["healthy"][0].figures
    apart = circles["weak"][0].figures
    lost = run_task("circle", "weak", seed=7, in_memory=True,
                    patient_options={"selectivity_loss": 0.5})[0].figures
    assert apart["circle_ratio"] > healthy["circle_ratio"]
    assert lost["circle_ratio"] < healthy["circle_ratio"] - 0.03
    assert lost["circle_joint_independence"] < healthy["circle_joint_independence"] - 0.05
    assert lost["circle_joint_independence"] < apart["circle_joint_independence"] - 0.05


@pytest.fixture(scope="module")
def ranges(tmp_path_factory):
    folder = tmp_path_factory.mktemp("range")
    return {kind: run_task("range", kind, seed=7, folder=folder)[0] for kind in KINDS}


def test_both_circles_hold_the_whole_tasks_figures(circles):
    keys = {spec.key for spec in task_figures("circle")}
    for kind, (cw, ccw) in circles.items():
        assert cw.parameters.clockwise
        assert not ccw.parameters.clockwise
        for trial in (cw, ccw):
            assert set(trial.figures) == keys, kind
            stored = read_trial(trial.path, ()).metrics
            for key in keys:
                assert stored[key] == pytest.approx(trial.figures[key], nan_ok=True)
        # the task's figure is the mean of the two ways
        mean = (cw.figures["circle_mean_speed_cw_m_s"] + cw.figures["circle_mean_speed_ccw_m_s"])
        assert cw.figures["circle_mean_speed_m_s"] == pytest.approx(mean / 2)


def test_the_circle_figures_order_healthy_weak_passive(circles):
    healthy, weak, passive = (circles[k][0].figures for k in KINDS)
    # the dot laps in 4 s (0.11 m/s on the 7 cm circle); a weak arm laps slower
    assert healthy["circle_mean_speed_m_s"] > weak["circle_mean_speed_m_s"] > 0.0
    assert passive["circle_mean_speed_m_s"] < 0.005
    assert healthy["circle_sparc"] > weak["circle_sparc"]
    assert healthy["circle_joint_independence"] > weak["circle_joint_independence"]
    for key in ("circle_ratio", "circle_sparc", "circle_joint_independence"):
        assert math.isfinite(healthy[key])
        assert math.isnan(passive[key]), key  # no circle drawn: nothing to measure


def test_the_range_figures_order_healthy_weak_passive(ranges):
    healthy, weak, passive = (ranges[k].figures for k in KINDS)
    assert healthy["range_area_ratio"] > 0.9  # out to 95 % of the way along each ray
    assert healthy["range_area_ratio"] > weak["range_area_ratio"] > 0.3
    assert passive["range_area_ratio"] == 0.0
    assert healthy["range_area_m2"] > weak["range_area_m2"] > passive["range_area_m2"]
    stored = read_trial(ranges["weak"].path, ()).metrics
    assert stored["range_area_ratio"] == pytest.approx(weak["range_area_ratio"])
