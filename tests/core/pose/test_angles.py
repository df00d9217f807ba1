"""Angles from table-plane keypoints against the arm's own model (known answers), ISB
display angles, gaps, the shoulder's drift and the solver rerun on a moving shoulder."""

from __future__ import annotations

import numpy as np
import pytest

from core.arm import ArmModel
from core.errors import ParameterError
from core.pose.angles import (
    arm_angles,
    isb_angles,
    shoulder_drift,
    solver_angles_with_shoulder,
    wrap,
)

SHOULDER = (-0.12, 0.73)


def keypoints_of(arm: ArmModel, theta: np.ndarray, shoulder=None) -> np.ndarray:
    """Keypoints (N, 4, 2) of postures theta (N, 2) from the arm's own forward kinematics;
    the other shoulder 0.35 m across."""
    s = np.broadcast_to(np.array(SHOULDER if shoulder is None else shoulder, float),
                        theta.shape).copy()
    e = arm.elbow_position(theta[:, 0], theta[:, 1])
    w = arm.position(theta[:, 0], theta[:, 1])
    shift = s - np.array([arm.shoulder_x_m, arm.shoulder_y_m])
    e = np.column_stack(e) + shift
    w = np.column_stack(w) + shift
    return np.stack((s, e, w, s + np.array([0.35, 0.0])), axis=1)


@pytest.mark.parametrize("side", ["right", "left"])
def test_angles_from_keypoints_match_the_solver_for_the_same_posture(side):
    arm = ArmModel.from_subject(91.0, 0.3048, 0.3048, SHOULDER, side=side)
    rng = np.random.default_rng(0)
    # hand positions over the reachable workspace in front of the shoulder
    hand = np.column_stack((rng.uniform(-0.45, 0.15, 500), rng.uniform(0.25, 0.55, 500)))
    theta_solver = arm.ik(hand)
    k = keypoints_of(arm, theta_solver)
    theta_camera = arm_angles(k)
    assert np.allclose(wrap(theta_camera - theta_solver), 0.0, atol=1e-12)
    # the same numbers, not just the same modulo 2π: the solver's branch
    assert np.allclose(theta_camera, theta_solver, atol=1e-12)
    assert np.allclose(isb_angles(arm, theta_camera), arm.isb_angles(theta_solver))


def test_a_right_arm_reads_the_thesis_display_angles():
    arm = ArmModel.from_subject(91.0, 0.30, 0.30, (0.0, 0.0))
    # upper arm straight along −y from the shoulder (θ_s = 90°), forearm across along +x
    # (θ_e = 180°): ISB shoulder 90° − θ_s = 0, elbow θ_e − θ_s = 90° of flexion
    k = np.array([[[0.0, 0.0], [0.0, -0.3], [0.3, -0.3], [0.35, 0.0]]])
    theta = arm_angles(k)
    assert np.allclose(np.degrees(theta), [[90.0, 180.0]])
    assert np.allclose(np.degrees(isb_angles(arm, theta)), [[0.0, 90.0]])


def test_a_gap_in_a_keypoint_is_a_gap_in_the_angles():
    arm = ArmModel.from_subject(91.0, 0.3048, 0.3048, SHOULDER)
    k = keypoints_of(arm, arm.ik([[-0.3, 0.4], [-0.2, 0.35], [-0.1, 0.4]]))
    k[0, 2] = np.nan  # wrist not seen
    k[1, 0] = np.nan  # shoulder not seen
    theta = arm_angles(k)
    assert np.isnan(theta[:2]).all()
    assert np.isfinite(theta[2]).all()
    with pytest.raises(ParameterError):
        arm_angles(np.zeros((2, 2)))


def test_drift_of_a_still_and_of_a_moving_shoulder():
    t = np.arange(0, 20, 1 / 30)
    rng = np.random.default_rng(1)
    still = np.array(SHOULDER) + rng.normal(0, 0.002, (t.size, 2))
    drift = shoulder_drift(t, still, SHOULDER, limit_m=0.03)
    assert not drift.exceeded
    assert drift.warning() is None
    assert drift.max_drift_m < 0.012
    assert drift.offset_m < 0.002
    # leans 5 cm to the side between 8 and 12 s, then back; set up 2 cm off
    lean = 0.05 * np.clip(np.minimum(t - 8, 12 - t), 0, 1)
    moving = np.column_stack((SHOULDER[0] + 0.02 + lean, np.full(t.size, SHOULDER[1])))
    moving[100:140] = np.nan  # not seen for a while
    drift = shoulder_drift(t, moving, SHOULDER, limit_m=0.03)
    assert drift.exceeded
    assert drift.max_drift_m == pytest.approx(0.05, abs=1e-9)
    assert np.allclose(drift.start_m, [SHOULDER[0] + 0.02, SHOULDER[1]])
    assert drift.offset_m == pytest.approx(0.02, abs=1e-9)
    # over 3 cm from 8.6 s to 11.4 s
    assert drift.time_over_s == pytest.approx(2.8, abs=0.1)
    assert np.isnan(drift.drift_m[100:140]).all()
    assert "5.0 cm" in drift.warning()
    assert "limit 3.0 cm" in drift.warning()
    with pytest.raises(ParameterError, match="all gaps"):
        shoulder_drift(t, np.full((t.size, 2), np.nan), SHOULDER)
    with pytest.raises(ParameterError, match="limit_m"):
        shoulder_drift(t, still, SHOULDER, limit_m=0)


def test_the_solver_on_the_cameras_shoulder_track_recovers_the_true_angles():
    arm = ArmModel.from_subject(91.0, 0.3048, 0.3048, SHOULDER)
    n = 200
    theta_true = np.column_stack((np.linspace(0.9, 1.3, n), np.linspace(2.4, 2.9, n)))
    track = np.array(SHOULDER) + np.column_stack((np.linspace(0, 0.04, n), np.zeros(n)))
    hand = keypoints_of(arm, theta_true)[:, 2] + (track - SHOULDER)
    fixed = arm.ik(hand)  # the solver assuming the shoulder still: wrong by the drift
    moving = solver_angles_with_shoulder(arm, hand, track)
    assert np.allclose(moving, theta_true, atol=1e-12)
    assert np.abs(fixed - theta_true).max() > np.radians(3)
    gap = track.copy()
    gap[5] = np.nan
    assert np.isnan(solver_angles_with_shoulder(arm, hand, gap)[5]).all()
