"""The robot's share of the work counts only its help (core.work.MechanicalWork,
core.control.own): the motors' torque that carries the robot's own friction, stiffness
and mass moves nothing of the patient. Measured in closed loop on the simulator's
realistic plant, the patient kinds' means (no trial-to-trial variation)."""

from functools import cache

import numpy as np
import pytest

from app.reports.metrics_table import format_metrics
from app.trials.analysis import analyse, exercise_mask, robots_own_torque
from app.trials.headless import simulate
from core.control.guidance import GuidanceGains
from core.robot import RobotModel
from core.trial import THESIS_SUBJECT


@cache
def run(patient: str, assist: str):
    params = THESIS_SUBJECT.replace(assist=assist)
    trial = simulate(params, patient=patient, seed=0, plant="realistic",
                     patient_options={"variability": 0.0})
    channels = {n: trial.records[n] for n in trial.records.dtype.names}
    return channels, params, analyse(channels, params).metrics


@pytest.mark.parametrize("assist", ["as-needed", "thesis"])
def test_a_passive_patient_is_moved_by_the_robots_help_alone(assist):
    m = run("passive", assist)[2]
    assert m.robot_work_share >= 0.95
    assert 0.0 < m.robot_help_work_J < m.robot_work_J  # the rest carried the robot itself


def test_a_healthy_patient_in_the_as_needed_mode_is_barely_helped():
    """The motors' net work counted, the share said 14 %; the help itself did none."""
    m = run("healthy", "as-needed")[2]
    assert m.robot_work_J > 0.1 * m.patient_work_J  # the motors did work, on the robot
    assert m.robot_work_share <= 0.05


@pytest.mark.parametrize("patient", ["weak", "healthy"])
def test_a_transparent_trial_gives_no_help(patient):
    """The motors only lighten the robot: the share was 37–40 %, it is none."""
    m = run(patient, "transparent")[2]
    assert m.robot_work_J > 0.3 * m.patient_work_J > 0.0
    assert abs(m.robot_help_work_J) <= 0.01 * m.patient_work_J
    assert m.robot_work_share <= 0.01


@pytest.mark.parametrize("assist", ["transparent", "as-needed"])
def test_the_robots_own_torque_is_the_one_its_mode_computed(assist):
    """Recomputed from the file's angles, rates and accelerations on the trial's model, the
    transparent torque is the controller's to rounding, and the as-needed mode's help
    (channel and help along the path) is what was commanded beyond it."""
    channels, params, _ = run("weak", assist)
    mask = exercise_mask(channels)
    own = robots_own_torque(lambda name: channels[name][mask], channels, params)
    if assist == "transparent":
        np.testing.assert_allclose(own, channels["torque_controller"][mask], atol=1e-12)
    else:
        # what is left of the controller's torque is the channel's J_Rᵀ F_n alone, a
        # force at the handle of at most its limit (core.control.guidance)
        j11, j12, j21, j22 = RobotModel().jacobian_terms(*channels["robot_angle"][mask].T)
        t1, t2 = (channels["torque_controller"][mask] - own).T
        det = j11 * j22 - j12 * j21
        fx, fy = (j22 * t1 - j21 * t2) / det, (-j12 * t1 + j11 * t2) / det
        channel = np.hypot(fx, fy)
        assert 1.0 < channel.max() <= GuidanceGains().channel_limit_N + 1e-9


def test_without_the_rates_the_share_is_unknown_not_the_motors_work():
    channels, params, _ = run("weak", "as-needed")
    partial = {k: v for k, v in channels.items() if k != "robot_rate"}
    m = analyse(partial, params).metrics
    assert np.isfinite(m.robot_work_J)
    assert np.isnan(m.robot_help_work_J)
    assert np.isnan(m.robot_work_share)


def test_the_printed_table_shows_the_help_beside_the_motors_work():
    """`rehab run` and the therapist's table (app.reports.metrics_table): the share is the
    help's, so the help's work is a row of its own beside the motors' net work."""
    m = run("passive", "as-needed")[2]
    table = format_metrics(m)
    assert f"Work of the robot's help{'':10}{m.robot_help_work_J:9.2f} J" in table
    assert f"Robot's net work{'':18}{m.robot_work_J:9.2f} J" in table


def test_a_figure_that_rounds_to_zero_reads_0_00_not_minus_0_00():
    """A transparent trial's help (−0.001 J: the rounding of two equal torques) read
    "Robot's help  -0.00 J" in `rehab run`'s table, as if the robot had held the hand back."""
    table = format_metrics({"robot_help_work_J": -0.001, "robot_work_J": -0.25})
    assert f"Work of the robot's help{'':10}{'0.00':>9} J" in table
    assert "-0.25 J" in table  # a negative figure that is one stays negative
    # the report's tables (app.reports.compare) show the same figure the same way
    from app.reports.compare import metric_text
    from app.reports.metrics_table import ROWS

    help_row = next(r for r in ROWS if r.key == "robot_help_work_J")
    assert metric_text(help_row, -0.001) == "0.00 J"
    # and the terminal's one-decimal figures (`rehab progress`: "-0.0 J")
    from app.cli.common import num

    assert (num(-0.04), num(-0.06), num(float("nan")), num(None)) == ("0.0", "-0.1", "–", "–")
