"""The camera-to-table homography on synthetic cameras with known answers: exact recovery,
outliers rejected, noise reported as a residual in mm, poor fits refused with the number."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ParameterError
from core.pose.homography import (
    PoorFitError,
    apply,
    fit_from_handle,
    fit_from_points,
)


def camera(tilt: float = 0.08) -> np.ndarray:
    """A camera over the table, slightly tilted: pixels -> plane (m). About 1.4 mm/px,
    y of the picture pointing down the table, perspective terms of a tilt."""
    plane_to_px = np.array([[700.0, 30.0, 520.0],
                            [-20.0, -690.0, 560.0],
                            [tilt, 0.05, 1.0]])
    return np.linalg.inv(plane_to_px) / np.linalg.inv(plane_to_px)[2, 2]


def handle_path(n: int = 300, seed: int = 1) -> np.ndarray:
    """A D-ish cloud of handle positions over the workspace, m."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 4 * np.pi, n)
    return np.column_stack((-0.25 + 0.12 * np.cos(t) + 0.01 * rng.standard_normal(n),
                            0.35 + 0.10 * np.sin(1.5 * t) + 0.01 * rng.standard_normal(n)))


def test_the_map_is_recovered_exactly_from_clean_detections():
    h_true = camera()
    plane = handle_path()
    px = apply(np.linalg.inv(h_true), plane)
    fit = fit_from_handle(px, plane)
    assert fit.residual_mm < 1e-6
    assert np.allclose(fit.matrix, h_true, rtol=1e-6, atol=1e-9)
    assert fit.inliers.all()
    assert np.allclose(fit.to_pixels(fit.to_plane(px)), px)


def test_outliers_are_rejected_and_the_noise_is_reported_in_mm():
    h_true = camera()
    plane = handle_path(400)
    rng = np.random.default_rng(3)
    px = apply(np.linalg.inv(h_true), plane) + rng.normal(0, 2.0, (400, 2))  # 2 px noise
    wrong = rng.choice(400, 80, replace=False)  # 20 % taken from the other hand or a blur
    px[wrong] += rng.uniform(60, 200, (80, 2)) * rng.choice([-1, 1], (80, 2))
    px[::37] = np.nan  # gaps: not seen
    fit = fit_from_handle(px, plane)
    assert not fit.inliers[wrong].any()
    assert fit.inliers.sum() >= 400 - 80 - 11 - 10
    # 2 px at about 1.4 mm/px: √2·2·1.4 ≈ 4 mm in the plane
    assert 2.0 < fit.residual_mm < 6.0
    clean = apply(np.linalg.inv(h_true), plane)
    err_mm = 1000 * np.linalg.norm(fit.to_plane(clean) - plane, axis=1)
    assert err_mm.max() < 2.0  # the map itself is far better than one detection
    assert "residual" in fit.describe()


def test_a_fit_with_a_large_residual_is_refused_with_the_number():
    plane = handle_path(200)
    rng = np.random.default_rng(4)
    px = apply(np.linalg.inv(camera()), plane) + rng.normal(0, 12.0, (200, 2))
    with pytest.raises(PoorFitError, match=r"residual in the table plane is \d+\.\d mm RMS "
                                           r"\(limit 10 mm\)"):
        fit_from_handle(px, plane, max_residual_mm=10, inlier_mm=80)


def test_mostly_wrong_detections_are_refused_with_the_count():
    plane = handle_path(100)
    rng = np.random.default_rng(5)
    px = rng.uniform(0, 640, (100, 2))  # the detector followed something else
    with pytest.raises(PoorFitError, match=r"only \d+ of 100 wrist detections agree"):
        fit_from_handle(px, plane)


def test_too_few_frames_or_a_line_of_positions_are_refused():
    plane = handle_path(5)
    with pytest.raises(PoorFitError, match="only 5 frames"):
        fit_from_handle(apply(np.linalg.inv(camera()), plane), plane)
    line = np.column_stack((np.linspace(-0.3, -0.1, 50), np.full(50, 0.4)))
    with pytest.raises(PoorFitError, match="along a line"):
        fit_from_handle(apply(np.linalg.inv(camera()), line), line)
    with pytest.raises(ParameterError):
        fit_from_handle(np.zeros((10, 3)), np.zeros((10, 2)))


def test_four_marked_points_fix_the_map_and_more_are_checked():
    h_true = camera()
    marks = np.array([[-0.45, 0.15], [0.05, 0.15], [0.05, 0.60], [-0.45, 0.60]])
    px = apply(np.linalg.inv(h_true), marks)
    fit = fit_from_points(px, marks)
    assert fit.exact
    assert fit.residual_mm == 0.0
    assert np.allclose(fit.matrix, h_true, rtol=1e-8, atol=1e-10)
    assert "exact" in fit.describe()
    six = np.vstack((marks, [[-0.2, 0.3], [-0.3, 0.5]]))
    six_px = apply(np.linalg.inv(h_true), six)
    six_px[4] += [5.0, 0.0]  # one mark clicked 5 px off
    fit = fit_from_points(six_px, six)
    assert not fit.exact
    assert 0.5 < fit.residual_mm < 7.0


def test_marked_points_that_cannot_fix_a_map_are_refused():
    marks = np.array([[-0.45, 0.15], [0.05, 0.15], [0.05, 0.60]])
    with pytest.raises(PoorFitError, match="3 marked points"):
        fit_from_points(apply(np.linalg.inv(camera()), marks), marks)
    collinear = np.array([[-0.4, 0.2], [-0.2, 0.2], [0.0, 0.2], [-0.2, 0.5]])
    with pytest.raises(PoorFitError, match="on one line"):
        fit_from_points(apply(np.linalg.inv(camera()), collinear), collinear)
    marks4 = np.array([[-0.45, 0.15], [0.05, 0.15], [0.05, 0.60], [-0.45, 0.60]])
    px = apply(np.linalg.inv(camera()), marks4)
    px[2] = np.nan
    with pytest.raises(ParameterError, match="finite pixels"):
        fit_from_points(px, marks4)


def test_auto_keeps_the_affine_map_unless_the_perspective_shows():
    plane = handle_path(300)
    rng = np.random.default_rng(6)
    noise = rng.normal(0, 2.0, (300, 2))
    square = camera(tilt=0.0)
    square[2] = [0.0, 0.0, 1.0]  # a camera square to the table: affine
    fit = fit_from_handle(apply(np.linalg.inv(square), plane) + noise, plane)
    assert np.allclose(fit.matrix[2, :2], 0.0)
    tilted = camera(tilt=1.5)  # strongly tilted: the projective terms are needed
    fit = fit_from_handle(apply(np.linalg.inv(tilted), plane) + noise, plane)
    assert not np.allclose(fit.matrix[2, :2], 0.0)
    forced = fit_from_handle(apply(np.linalg.inv(tilted), plane) + noise, plane,
                             model="affine", max_residual_mm=100)
    assert np.allclose(forced.matrix[2, :2], 0.0)
    assert forced.residual_mm > fit.residual_mm
    with pytest.raises(ParameterError, match="model"):
        fit_from_handle(apply(np.linalg.inv(tilted), plane), plane, model="cubic")


def test_a_wrist_seen_only_before_the_movement_is_said_so_not_blamed_on_the_path():
    """The wrist seen in 22 of 298 frames, all before the movement (the arm then out of the
    picture): the refusal said the handle's path was a line and advised a trial with a 2-D
    path, which this trial had."""
    frames = 298
    t = np.arange(frames) / 30.0
    still = np.tile([-0.25, 0.35], (30, 1))
    plane = np.vstack((still, handle_path(frames - 30)))
    px = apply(np.linalg.inv(camera()), plane)
    px[22:] = np.nan
    with pytest.raises(PoorFitError) as caught:
        fit_from_handle(px, plane, frame_t_s=t)
    assert str(caught.value) == (
        "the wrist was seen in only 22 of 298 frames (from 0.0 s to 0.7 s, all before the "
        "handle moved), where the handle's positions lie along a line or in one spot (0 mm "
        "RMS across it) though the trial's path spans the plane; the camera did not see "
        "the arm through the movement (out of the picture, or the camera turned): check "
        "that it sees the whole arm and run the pose again, or calibrate from four marked "
        "points")
    with pytest.raises(PoorFitError, match=r"only 22 of 298 frames \(frames 1 to 22, all "
                                           r"before the handle moved\)"):
        fit_from_handle(px, plane)
