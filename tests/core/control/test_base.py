"""The controller interface and its factory."""

import math

import pytest

import core.trial
from core.control import (
    CONTROLLER_NAMES,
    ComputedTorquePID,
    Controller,
    CTPIDGains,
    SlidingModeController,
    SMCGains,
    make_controller,
)
from core.errors import ParameterError
from core.robot import RobotModel

ROBOT = RobotModel()
Q = tuple(float(v) for v in ROBOT.ik([-0.3, 0.3]))


@pytest.mark.parametrize(
    ("name", "cls"), [("smc", SlidingModeController), ("ctpid", ComputedTorquePID)]
)
def test_factory_builds_each_controller_with_the_drive_limit(name, cls):
    ctrl = make_controller(name, ROBOT)
    assert isinstance(ctrl, cls)
    assert isinstance(ctrl, Controller)
    assert ctrl.name == name
    assert ctrl.torque_limit_Nm == ROBOT.max_joint_torque_Nm
    tau = ctrl.step(0.002, *Q, 0.1, -0.2, Q[0] + 0.001, Q[1], 0.1, -0.1, 0.3, 0.2)
    # plain floats out, so the loop never touches numpy scalars
    assert type(tau) is tuple
    assert all(type(t) is float and math.isfinite(t) for t in tau)


def test_names_agree_with_the_trial_parameters():
    assert set(CONTROLLER_NAMES) == set(core.trial.CONTROLLERS)


def test_unknown_name_is_refused_by_name():
    with pytest.raises(ParameterError) as info:
        make_controller("lqr", ROBOT)
    assert info.value.field == "controller"
    assert "smc" in str(info.value)
    assert "ctpid" in str(info.value)


def test_gains_of_the_other_controller_are_refused():
    with pytest.raises(ParameterError, match="gains"):
        make_controller("smc", ROBOT, gains=CTPIDGains())
    with pytest.raises(ParameterError, match="gains"):
        make_controller("ctpid", ROBOT, gains=SMCGains())
    ctrl = make_controller("smc", ROBOT, gains=SMCGains(lambda_1_s=(5.0, 6.0)))
    assert ctrl.gains.lambda_1_s == (5.0, 6.0)


@pytest.mark.parametrize(
    ("limit", "field"),
    [((0.0, 1.0), "torque_limit_Nm[0]"), ((1.0, math.nan), "torque_limit_Nm[1]"),
     (2.0, "torque_limit_Nm"), ((1.0, 2.0, 3.0), "torque_limit_Nm")],
)
def test_bad_torque_limit_is_refused_by_name(limit, field):
    for name in CONTROLLER_NAMES:
        with pytest.raises(ParameterError) as info:
            make_controller(name, ROBOT, torque_limit_Nm=limit)
        assert info.value.field == field


def test_model_without_a_drive_limit_needs_an_explicit_one():
    class Learned:
        def inverse_dynamics_terms(self, q1, q2, qd1, qd2, qdd1, qdd2, fx=0.0, fy=0.0):
            return (qdd1, qdd2)

    with pytest.raises(ParameterError, match="torque_limit_Nm"):
        make_controller("ctpid", Learned())
    ctrl = make_controller("ctpid", Learned(), torque_limit_Nm=(1.0, 1.0))
    assert ctrl.torque_limit_Nm == (1.0, 1.0)
