"""A known camera over a simulated trial: the arm's keypoints projected into pixels with
noise, dropped frames, unseen keypoints and wrong detections, as a detector would report
them. For the whole-pipeline test and the benchmark (bench/pose.py): the same code runs
on these as on a real detector's output, and the answer is known.

The arm is the trial's own, its hand on the handle and its shoulder fixed where the
parameters put it, so without a drift the true angles are the solver's and the camera's
differ from them only by what the camera adds; with a drift the true angles are the
solver's on the moved shoulder.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from app.trials.reader import TrialData
from core.pose.angles import solver_angles_with_shoulder
from core.pose.homography import apply
from core.pose.keypoints import WRIST

FPS = 30.0
IMAGE_SIZE = (640, 480)  # width, height
SHOULDER_WIDTH_M = 0.38


@dataclass(frozen=True, slots=True)
class SyntheticVideo:
    """What a detector would have reported: `stamps_s` (F,) monotonic, `keypoints_px`
    (F, 4, 2), `visibility` (F, 4); `true_frame_t_s` (F,) the trial time each frame was
    taken; `camera` (3×3, plane -> pixels); `origin_s` the trial's wall-time origin."""

    stamps_s: np.ndarray
    keypoints_px: np.ndarray
    visibility: np.ndarray
    true_frame_t_s: np.ndarray
    camera: np.ndarray
    origin_s: float


def overhead_camera(points_m: np.ndarray, tilt: float = 0.1) -> np.ndarray:
    """A plane -> pixel homography that fits `points_m` (…, 2) into a 640×480 picture with a
    margin, the table's y axis down the picture, with a perspective tilt."""
    pts = points_m.reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    width, height = IMAGE_SIZE
    scale = 0.85 * min(width / (hi[0] - lo[0]), height / (hi[1] - lo[1]))
    centre = (lo + hi) / 2
    affine = np.array([[scale, 0.0, width / 2 - scale * centre[0]],
                       [0.0, -scale, height / 2 + scale * centre[1]],
                       [0.0, 0.0, 1.0]])
    # a camera not quite square to the table: a small projective term about the centre
    to_centre = np.array([[1.0, 0, -centre[0]], [0, 1.0, -centre[1]], [0, 0, 1.0]])
    tilt_m = np.array([[1.0, 0, 0], [0, 1.0, 0], [tilt, 0.5 * tilt, 1.0]])
    h = affine @ np.linalg.inv(to_centre) @ tilt_m @ to_centre
    return h / h[2, 2]


def arm_keypoints_m(trial: TrialData, shoulder_drift_m=None) -> np.ndarray:
    """The arm's keypoints (N, 4, 2) at every sample: the wrist on the handle, the shoulder
    where the parameters put it (moved by `shoulder_drift_m` (N, 2) when given), the elbow
    where the arm's segments put it between the two, the other shoulder across."""
    arm = trial.parameters.arm()
    hand = np.asarray(trial.channels["position"], dtype=float)
    n = hand.shape[0]
    shift = np.zeros((n, 2)) if shoulder_drift_m is None else np.asarray(shoulder_drift_m)
    shoulder = np.array([arm.shoulder_x_m, arm.shoulder_y_m]) + shift
    theta = solver_angles_with_shoulder(arm, hand, shoulder)
    elbow = np.column_stack(arm.elbow_position(theta[:, 0], theta[:, 1])) + shift
    across = np.array([SHOULDER_WIDTH_M * arm.elbow_sign, 0.0])
    return np.stack((shoulder, elbow, hand, shoulder + across), axis=1)


def film(trial: TrialData, *, noise_px: float = 2.0, drop_fraction: float = 0.05,
         unseen_fraction: float = 0.03, wrong_fraction: float = 0.02,
         shoulder_drift_m=None, seed: int = 0, origin_s: float = 5000.0) -> SyntheticVideo:
    """Film a trial at 30 fps through a known camera. Frames are taken on the trial's clock,
    stamped on the monotonic clock through the trial's own wall_time (with 2 ms of jitter),
    some dropped; every keypoint gets Gaussian pixel noise, some are unseen (visibility
    0.2) and some wrists are wrong (the detector followed something else, 40–150 px off,
    visibility still high)."""
    rng = np.random.default_rng(seed)
    t = np.asarray(trial.channels["time"], dtype=float)
    wall = np.asarray(trial.channels["wall_time"], dtype=float)
    keypoints = arm_keypoints_m(trial, shoulder_drift_m)
    camera = overhead_camera(keypoints)
    taken = np.arange(t[0] - 0.2, t[-1] + 0.2, 1.0 / FPS)
    taken = taken[rng.random(taken.size) >= drop_fraction]
    # where the arm was at each frame (linear between samples; held at the ends)
    at = np.stack([np.stack([np.interp(taken, t, keypoints[:, k, j]) for j in range(2)],
                            axis=-1) for k in range(4)], axis=1)
    px = apply(camera, at) + rng.normal(0.0, noise_px, at.shape)
    visibility = rng.uniform(0.8, 1.0, (taken.size, 4))
    unseen = rng.random((taken.size, 4)) < unseen_fraction
    visibility[unseen] = 0.2
    wrong = rng.random(taken.size) < wrong_fraction
    px[wrong, WRIST] += rng.uniform(40, 150, (wrong.sum(), 2)) * rng.choice([-1, 1],
                                                                           (wrong.sum(), 2))
    wall_at = np.interp(taken, t, wall) + (taken - np.clip(taken, t[0], t[-1]))
    stamps = origin_s + wall_at + rng.normal(0.0, 0.002, taken.size)
    stamps = np.maximum.accumulate(stamps + 1e-6 * np.arange(taken.size))
    return SyntheticVideo(stamps, px, visibility, taken, camera, origin_s)

