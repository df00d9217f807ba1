"""Everything after the detector, on arrays: from each frame's keypoints in pixels and its
time on the trial's clock to the subject's angles on the trial's 2 ms samples, the
shoulder's drift, and the camera against the equation solver (Table 3.4).

The steps, each in its own module of this room:
1. low-visibility keypoints become gaps (`keypoints.with_gaps`);
2. the camera-to-table map: given (four marked points, `homography.fit_from_points`) or
   fitted over the trial from the wrist against the handle (`homography.fit_from_handle`);
3. keypoints into the table plane, and the angles of each frame (`angles.arm_angles`);
4. the 30 fps angles and shoulder onto the samples, gaps kept (`timebase.resample`);
5. ISB display angles, the shoulder's drift, the solver rerun on the camera's shoulder,
   and the errors per joint against the solver (`compare.joint_errors`, on the ISB angles
   as Table 3.4 compares them).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.arm import ArmModel
from core.errors import ParameterError
from core.pose.angles import (
    DEFAULT_DRIFT_LIMIT_M,
    ShoulderDrift,
    arm_angles,
    shoulder_drift,
    solver_angles_with_shoulder,
    wrap,
)
from core.pose.compare import JointError, joint_errors
from core.pose.homography import (
    DEFAULT_INLIER_MM,
    DEFAULT_MAX_RESIDUAL_MM,
    Homography,
    fit_from_handle,
    refine_with_lengths,
)
from core.pose.keypoints import DEFAULT_MIN_VISIBILITY, ELBOW, SHOULDER, WRIST, with_gaps
from core.pose.timebase import resample


@dataclass(frozen=True, slots=True)
class PoseResult:
    """The camera's view of one trial.

    Per frame (F): `frame_time_s`, `keypoints_m` (F, 4, 2) in the table plane (gaps NaN),
    `frame_angle` (F, 2) absolute (θ_s, θ_e). Per sample (N): `angle` (N, 2) absolute,
    `angle_isb` (N, 2) for display, `shoulder_m` (N, 2), `solver_angle_camera_shoulder`
    (N, 2): the solver rerun with the camera's shoulder. `errors`: camera − solver per
    joint on the ISB angles; `errors_camera_shoulder`: the same for the solver rerun;
    `drift`: the shoulder's drift; `homography`: the map used."""

    homography: Homography
    frame_time_s: np.ndarray
    keypoints_m: np.ndarray
    frame_angle: np.ndarray
    angle: np.ndarray
    angle_isb: np.ndarray
    shoulder_m: np.ndarray
    solver_angle_camera_shoulder: np.ndarray
    errors: tuple[JointError, JointError]
    errors_camera_shoulder: tuple[JointError, JointError]
    drift: ShoulderDrift
    frames_seen: int

    @property
    def frames(self) -> int:
        return int(self.frame_time_s.size)


def handle_at_frames(sample_t_s, hand_m, frame_t_s) -> np.ndarray:
    """The handle's position (F, 2) at each frame's time, linear between samples; NaN for
    frames outside the trial."""
    t = np.asarray(sample_t_s, dtype=float)
    hand = np.asarray(hand_m, dtype=float)
    ft = np.asarray(frame_t_s, dtype=float)
    out = np.column_stack([np.interp(ft, t, hand[:, j]) for j in range(2)])
    out[(ft < t[0]) | (ft > t[-1])] = np.nan
    return out


def pose_from_keypoints(
    arm: ArmModel,
    sample_t_s,
    hand_m,
    solver_angle,
    frame_t_s,
    keypoints_px,
    visibility,
    *,
    homography: Homography | None = None,
    min_visibility: float = DEFAULT_MIN_VISIBILITY,
    max_residual_mm: float = DEFAULT_MAX_RESIDUAL_MM,
    inlier_mm: float = DEFAULT_INLIER_MM,
    drift_limit_m: float = DEFAULT_DRIFT_LIMIT_M,
) -> PoseResult:
    """The whole pipeline after the detector.

    `sample_t_s` (N,), `hand_m` (N, 2) the handle's positions (encoders), `solver_angle`
    (N, 2) the solver's absolute angles (the `subject_angle` channel); `frame_t_s` (F,)
    each frame on the trial's clock, `keypoints_px` (F, 4, 2) and `visibility` (F, 4)
    from the detector. Without `homography` the map is fitted from the handle. A wrist
    further than `inlier_mm` from the handle is a gap. Raises PoorFitError when the map is
    unusable."""
    t = np.asarray(sample_t_s, dtype=float)
    hand = np.asarray(hand_m, dtype=float)
    solver = np.asarray(solver_angle, dtype=float)
    ft = np.asarray(frame_t_s, dtype=float)
    if hand.shape != (t.size, 2) or solver.shape != (t.size, 2):
        raise ParameterError("hand_m", hand.shape, f"({t.size}, 2), like solver_angle")
    px = with_gaps(keypoints_px, visibility, min_visibility)
    if px.shape != (ft.size, 4, 2):
        raise ParameterError("keypoints_px", px.shape, f"({ft.size}, 4, 2): one set per frame")
    handle = handle_at_frames(t, hand, ft)
    if homography is None:
        homography = fit_from_handle(px[:, WRIST], handle, max_residual_mm=max_residual_mm,
                                     inlier_mm=inlier_mm, frame_t_s=ft)
        homography = refine_with_lengths(homography, px[:, WRIST], handle, px[:, SHOULDER],
                                         px[:, ELBOW], arm.upper_arm_m, arm.forearm_m,
                                         max_residual_mm=max_residual_mm)
    plane = homography.to_plane(px)
    # the hand is on the handle: a wrist seen far from it is the detector's mistake (the
    # other hand, a blur), a gap rather than an angle
    off = np.linalg.norm(plane[:, WRIST] - handle, axis=1) > inlier_mm / 1000.0
    plane[off & np.isfinite(handle).all(axis=1), WRIST] = np.nan
    frame_angle = arm_angles(plane)
    angle = resample(ft, frame_angle, t, angles=True)
    shoulder = resample(ft, plane[:, SHOULDER], t)
    # the solver's θ_s comes from atan2, in (−π, π]: bring the camera's unwrapped series
    # onto the same turn, sample by sample, so both read the same numbers
    angle = np.where(np.isfinite(solver), solver + wrap(angle - solver), angle)
    isb = arm.isb_angles(angle)
    solver_isb = arm.isb_angles(solver)
    moving = solver_angles_with_shoulder(arm, hand, shoulder)
    drift = shoulder_drift(t, shoulder, (arm.shoulder_x_m, arm.shoulder_y_m),
                           limit_m=drift_limit_m)
    return PoseResult(
        homography=homography,
        frame_time_s=ft,
        keypoints_m=plane,
        frame_angle=frame_angle,
        angle=angle,
        angle_isb=isb,
        shoulder_m=shoulder,
        solver_angle_camera_shoulder=moving,
        errors=joint_errors(solver_isb, isb),
        errors_camera_shoulder=joint_errors(arm.isb_angles(moving), isb),
        drift=drift,
        frames_seen=int(np.count_nonzero(np.isfinite(frame_angle).all(axis=1))),
    )
