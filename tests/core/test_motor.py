"""The drive: Table 3.1's torque constant, gear, rated torque and encoder."""

import math

import pytest

from core.errors import ParameterError
from core.motor import MotorParameters

MOTOR = MotorParameters()


def test_limits_from_the_rated_torque():
    assert MOTOR.max_current_A == pytest.approx(1.0)  # 0.115 N·m / 0.115 N·m/A
    assert MOTOR.max_joint_torque_Nm == pytest.approx(0.115 * 307 / 16)


def test_torque_current_round_trip():
    assert MOTOR.current_from_joint_torque(1.5) == pytest.approx(1.5 / (0.115 * 307 / 16))
    assert MOTOR.joint_torque_from_current(MOTOR.current_from_joint_torque(1.5)) == (
        pytest.approx(1.5)
    )


def test_encoder_on_the_motor_shaft_resolves_the_joint_finer():
    assert MOTOR.counts_per_joint_rev == pytest.approx(4000 * 307 / 16)
    assert MOTOR.joint_angle_resolution_rad == pytest.approx(2 * math.pi / (4000 * 307 / 16))
    on_joint = MotorParameters(encoder_on_motor=False)
    assert on_joint.joint_angle_resolution_rad == pytest.approx(2 * math.pi / 4000)


def test_quantisation_error_is_at_most_half_a_count():
    res = MOTOR.joint_angle_resolution_rad
    for k in range(1000):
        angle = -3.0 + 0.006137 * k
        assert abs(MOTOR.quantise_joint_angle(angle) - angle) <= 0.5 * res + 1e-15


@pytest.mark.parametrize("field", ["torque_constant_Nm_per_A", "gear_ratio", "rated_torque_Nm"])
def test_non_positive_values_are_refused(field):
    with pytest.raises(ParameterError, match=field):
        MotorParameters(**{field: 0.0})
