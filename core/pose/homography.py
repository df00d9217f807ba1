"""From the camera's picture to the table plane: a plane-to-plane homography.

The arm moves in the horizontal plane of the handle (the thesis's planar model, section
3.3), and a camera sees that plane through a projective map: a 3×3 matrix H with

    [X, Y, 1]ᵀ ∝ H [u, v, 1]ᵀ

from pixels (u right, v down) to the global frame (m, docs/frames.md). Two ways to find H:

* `fit_from_handle`: over a trial, the handle's known positions (the encoders' forward
  kinematics, the `position` channel) against the wrist the detector found at the same
  instants. Detections are noisy and some are wrong (the other hand taken for this one,
  a blur), so the fit is robust: RANSAC over four-point samples picks the consistent
  pairs, then a Huber-loss least squares on those refines H against the error in the
  plane. The wrist is not the handle's centre (the hand grips it a few cm further on), so
  the residual includes that offset as well as the detector's noise. The map is affine
  unless the data show perspective (`model`), and `refine_with_lengths` then ties it down
  beyond the handle's patch with the subject's segment lengths.
* `fit_from_points`: four or more marks on the table whose positions were measured, found
  in the picture by hand when the robot is still; with exactly four the map is exact and
  there is nothing to check it against, so the residual is reported as 0 with that said.

Either way the fit reports its residual in mm in the table plane, and refuses (PoorFitError,
with the number) a fit too poor to measure joint angles with.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from core.errors import CoreError, ParameterError, check_positive, check_range

# A residual in the plane above this makes the angles unusable: 15 mm across a 0.3 m
# segment is about 3°, four times the thesis's pose estimator's error (Table 3.4).
DEFAULT_MAX_RESIDUAL_MM = 15.0
# RANSAC's inlier distance in the plane: a few detector pixels plus the wrist-handle offset.
DEFAULT_INLIER_MM = 25.0
# Fewer inliers than this share of the pairs means the detector followed something else.
MIN_INLIER_FRACTION = 0.5
MIN_PAIRS = 8
MIN_SPREAD_M = 0.01
"""The handle's positions must stray at least this far (RMS) from a line: a line of
points leaves the map's other direction free."""
RANSAC_ITERATIONS = 500
MODELS = ("auto", "affine", "projective")
# The F statistic above which the two perspective parameters earn their place.
AFFINE_F_LIMIT = 20.0


class PoorFitError(CoreError, ValueError):
    """The camera-to-table map cannot be trusted: too few points, degenerate, or a residual
    above the limit. The message gives the number and what to do."""


@dataclass(frozen=True, slots=True)
class Homography:
    """H (3×3, pixels -> m, H[2, 2] = 1) with how well it fitted.

    `residual_mm`: RMS distance in the plane between mapped and known points, over the
    inliers; `max_residual_mm` the largest of those; `inliers` (N,) which pairs were used;
    `method`: "handle" or "points"; `exact`: True when four points fixed H with none to
    spare (the residual then proves nothing)."""

    matrix: np.ndarray
    residual_mm: float
    max_residual_mm: float
    inliers: np.ndarray
    method: str
    exact: bool = False

    @property
    def n_inliers(self) -> int:
        return int(np.count_nonzero(self.inliers))

    @property
    def inlier_fraction(self) -> float:
        return self.n_inliers / self.inliers.size if self.inliers.size else 0.0

    def to_plane(self, xy_px) -> np.ndarray:
        """Pixels (..., 2) to the table plane (..., 2), m. NaN stays NaN."""
        return apply(self.matrix, xy_px)

    def to_pixels(self, xy_m) -> np.ndarray:
        """The table plane (..., 2), m, to pixels (..., 2)."""
        return apply(np.linalg.inv(self.matrix), xy_m)

    def describe(self) -> str:
        if self.exact:
            return f"{self.method} fit from 4 points: exact, nothing left to check it against"
        return (f"{self.method} fit: residual {self.residual_mm:.1f} mm RMS "
                f"({self.max_residual_mm:.1f} mm at most) over {self.n_inliers} of "
                f"{self.inliers.size} points")


def apply(matrix, xy) -> np.ndarray:
    """The projective map of a 3×3 matrix on points (..., 2)."""
    xy = np.asarray(xy, dtype=float)
    h = np.asarray(matrix, dtype=float)
    x, y = xy[..., 0], xy[..., 1]
    w = h[2, 0] * x + h[2, 1] * y + h[2, 2]
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.stack(((h[0, 0] * x + h[0, 1] * y + h[0, 2]) / w,
                         (h[1, 0] * x + h[1, 1] * y + h[1, 2]) / w), axis=-1)


def fit_from_handle(
    wrist_px,
    handle_m,
    *,
    max_residual_mm: float = DEFAULT_MAX_RESIDUAL_MM,
    inlier_mm: float = DEFAULT_INLIER_MM,
    model: str = "auto",
    seed: int = 0,
    frame_t_s=None,
) -> Homography:
    """H from the detected wrist (N, 2) px against the handle's positions (N, 2) m at the
    same instants; rows with a NaN (gaps) are left out. RANSAC, then Huber least squares
    on the inliers. Raises PoorFitError when fewer than half the pairs agree or the
    residual exceeds `max_residual_mm`; `frame_t_s` (N,), each frame's time, only lets
    a refusal say when the wrist was seen.

    `model`: "projective" (8 parameters), "affine" (6: a camera square to the table), or
    "auto": the affine map unless the projective one fits the inliers significantly
    better (an F-test at F > AFFINE_F_LIMIT). Why: the handle covers only the exercise's
    patch of the table, while the shoulder and elbow lie up to half a metre beyond it; the
    two perspective parameters, weakly fixed by a small patch, then extrapolate the
    detector's noise into centimetres at the shoulder. A camera tilted enough for its
    perspective to show within the patch is still fitted projectively."""
    check_positive("max_residual_mm", max_residual_mm, "mm")
    if model not in MODELS:
        raise ParameterError("model", model, " or ".join(repr(m) for m in MODELS))
    check_positive("inlier_mm", inlier_mm, "mm")
    src, dst, rows = _pairs(wrist_px, handle_m)
    if src.shape[0] < MIN_PAIRS:
        raise PoorFitError(
            f"only {src.shape[0]} frames have both a visible wrist and a handle position; "
            f"the camera fit needs at least {MIN_PAIRS}. Check the camera sees the arm, or "
            "calibrate from four marked points")
    if _spread_m(dst) < MIN_SPREAD_M:
        raise PoorFitError(_unspread(wrist_px, handle_m, rows, frame_t_s))
    tolerance_m = inlier_mm / 1000.0
    rng = np.random.default_rng(seed)
    best = None
    n = src.shape[0]
    for _ in range(RANSAC_ITERATIONS):
        pick = rng.choice(n, 4, replace=False)
        if _degenerate(src[pick]) or _degenerate(dst[pick]):
            continue
        h = _dlt(src[pick], dst[pick])
        if h is None:
            continue
        inliers = _distances(h, src, dst) < tolerance_m
        count = int(np.count_nonzero(inliers))
        if best is None or count > best[0]:
            best = (count, inliers)
            if count == n:
                break
    if best is None or best[0] < max(MIN_PAIRS, MIN_INLIER_FRACTION * n):
        agreed = 0 if best is None else best[0]
        raise PoorFitError(
            f"the camera fit is too poor to use: only {agreed} of {n} wrist detections agree "
            f"with the handle within {inlier_mm:g} mm (at least half must). The detector "
            "may be following the other arm or the camera moved; calibrate from four "
            "marked points")
    inliers = best[1]
    h = _dlt(src[inliers], dst[inliers])
    h = _refine(h, src[inliers], dst[inliers], tolerance_m / 3.0)
    # the refined map may take in pairs RANSAC's sample missed
    inliers = _distances(h, src, dst) < tolerance_m
    h = _refine(h, src[inliers], dst[inliers], tolerance_m / 3.0)
    if model != "projective":
        affine = _refine(_affine(src[inliers], dst[inliers]), src[inliers], dst[inliers],
                         tolerance_m / 3.0, affine=True)
        if model == "affine" or not _projective_needed(affine, h, src[inliers],
                                                       dst[inliers]):
            h = affine
            inliers = _distances(h, src, dst) < tolerance_m
    mask = np.zeros(np.asarray(wrist_px).shape[0], bool)
    mask[rows[inliers]] = True
    return _checked(h, src[inliers], dst[inliers], mask, "handle", max_residual_mm)


def fit_from_points(
    points_px, points_m, *, max_residual_mm: float = DEFAULT_MAX_RESIDUAL_MM
) -> Homography:
    """H from four or more marked points: their pixels (K, 2) and measured positions
    (K, 2) m. Least squares (no outlier rejection: every mark was placed on purpose)."""
    check_positive("max_residual_mm", max_residual_mm, "mm")
    src, dst, _ = _pairs(points_px, points_m)
    if src.shape[0] != np.asarray(points_px).shape[0]:
        raise ParameterError("points", "a NaN", "finite pixels and positions for every mark")
    if src.shape[0] < 4:
        raise PoorFitError(f"{src.shape[0]} marked points given; the camera fit needs at "
                           "least 4, no three of them on one line")
    if _degenerate(src) or _degenerate(dst):
        raise PoorFitError("three of the marked points lie on one line (in the picture or "
                           "on the table); mark four corners of a quadrilateral")
    h = _dlt(src, dst)
    if h is None:
        raise PoorFitError("the marked points do not determine a camera map; mark four "
                           "corners of a quadrilateral")
    if src.shape[0] > 4:
        h = _refine(h, src, dst, None)
    return _checked(h, src, dst, np.ones(src.shape[0], bool), "points", max_residual_mm,
                    exact=src.shape[0] == 4)


# -- the parts --------------------------------------------------------------------


def _pairs(px, m) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    px = np.asarray(px, dtype=float)
    m = np.asarray(m, dtype=float)
    if px.ndim != 2 or px.shape[1] != 2 or px.shape != m.shape:
        raise ParameterError("points", f"{px.shape} and {m.shape}",
                             "pixels and positions as two (N, 2) arrays of the same length")
    rows = np.flatnonzero(np.isfinite(px).all(axis=1) & np.isfinite(m).all(axis=1))
    return px[rows], m[rows], rows


def _spread_m(dst: np.ndarray) -> float:
    """The RMS distance of points (N, 2) m from their best line: 0 on a line or a spot."""
    return float(np.linalg.svd(dst - dst.mean(axis=0), compute_uv=False)[-1]
                 / np.sqrt(len(dst)))


def _unspread(wrist_px, handle_m, rows: np.ndarray, frame_t_s) -> str:
    """Why the handle's positions at the frames with a wrist do not span the plane, and
    what to do: the trial's own path was a line or a spot (choose another trial), or the
    path spanned the plane but the detector saw the wrist in only part of it (the arm out
    of the picture, the camera turned), where "use a 2-D path" misled."""
    handle = np.asarray(handle_m, dtype=float)
    used = handle[rows]
    across = _spread_m(used)
    on_path = np.flatnonzero(np.isfinite(handle).all(axis=1))
    if _spread_m(handle[on_path]) < MIN_SPREAD_M:
        return (f"the handle's positions lie along a line or in one spot ({1000 * across:.0f}"
                " mm RMS across it); the camera fit needs movement in two directions: use a "
                "trial with a 2-D path, or calibrate from four marked points")
    start = handle[on_path[0]]
    moved = on_path[np.linalg.norm(handle[on_path] - start, axis=1) > MIN_SPREAD_M]
    if moved.size and rows[-1] < moved[0]:
        phase = ", all before the handle moved"
    elif moved.size and rows[0] > moved[-1]:
        phase = ", all after the handle stopped"
    else:
        phase = ""
    total = np.asarray(wrist_px).shape[0]
    return (f"the wrist was seen in only {rows.size} of {total} frames "
            f"({_when(rows, frame_t_s)}{phase}), where the handle's positions lie along a "
            f"line or in one spot ({1000 * across:.0f} mm RMS across it) though the trial's "
            "path spans the plane; the camera did not see the arm through the movement "
            "(out of the picture, or the camera turned): check that it sees the whole arm "
            "and run the pose again, or calibrate from four marked points")


def _when(rows: np.ndarray, frame_t_s) -> str:
    """The first and last of the frames `rows` (0-based), as times when known."""
    if frame_t_s is not None:
        t = np.asarray(frame_t_s, dtype=float)
        if t.ndim == 1 and t.size > rows[-1]:
            return f"from {t[rows[0]]:.1f} s to {t[rows[-1]]:.1f} s"
    return f"frames {rows[0] + 1} to {rows[-1] + 1}"


def _normaliser(points: np.ndarray) -> np.ndarray:
    """Hartley's normalisation: centroid to the origin, mean distance √2."""
    centre = points.mean(axis=0)
    scale = np.sqrt(2.0) / max(np.mean(np.linalg.norm(points - centre, axis=1)), 1e-12)
    return np.array([[scale, 0.0, -scale * centre[0]],
                     [0.0, scale, -scale * centre[1]],
                     [0.0, 0.0, 1.0]])


def _dlt(src: np.ndarray, dst: np.ndarray) -> np.ndarray | None:
    """The direct linear transform on normalised points; None when degenerate."""
    ts, td = _normaliser(src), _normaliser(dst)
    s = apply(ts, src)
    d = apply(td, dst)
    zeros = np.zeros(len(s))
    ones = np.ones(len(s))
    rows_x = np.column_stack((s[:, 0], s[:, 1], ones, zeros, zeros, zeros,
                              -d[:, 0] * s[:, 0], -d[:, 0] * s[:, 1], -d[:, 0]))
    rows_y = np.column_stack((zeros, zeros, zeros, s[:, 0], s[:, 1], ones,
                              -d[:, 1] * s[:, 0], -d[:, 1] * s[:, 1], -d[:, 1]))
    a = np.vstack((rows_x, rows_y))
    _, sv, vt = np.linalg.svd(a)
    if len(sv) >= 8 and sv[7] < 1e-10 * sv[0]:
        return None
    h = np.linalg.inv(td) @ vt[-1].reshape(3, 3) @ ts
    if abs(h[2, 2]) < 1e-15:
        return None
    return h / h[2, 2]


def _affine(src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    """The least-squares affine map (last row 0, 0, 1)."""
    a = np.column_stack((src, np.ones(len(src))))
    coefficients, *_ = np.linalg.lstsq(a, dst, rcond=None)
    return np.vstack((coefficients.T, [0.0, 0.0, 1.0]))


def _projective_needed(affine, projective, src, dst) -> bool:
    """An F-test of the projective map's two extra parameters against the affine map."""
    rss_a = float(np.sum(_distances(affine, src, dst) ** 2))
    rss_p = float(np.sum(_distances(projective, src, dst) ** 2))
    dof = 2 * len(src) - 8
    if dof <= 0 or rss_p <= 0:
        return rss_p < rss_a
    return ((rss_a - rss_p) / 2.0) / (rss_p / dof) > AFFINE_F_LIMIT


def _degenerate(points: np.ndarray) -> bool:
    """True when some three of the points are (nearly) on one line."""
    n = len(points)
    size = np.ptp(points, axis=0).max()
    if size <= 0:
        return True
    for i in range(n):
        for j in range(i + 1, n):
            for k in range(j + 1, n):
                a, b, c = points[i], points[j], points[k]
                area = abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]))
                if area < 1e-4 * size * size:
                    return True
    return False


def _distances(h: np.ndarray, src: np.ndarray, dst: np.ndarray) -> np.ndarray:
    d = np.linalg.norm(apply(h, src) - dst, axis=1)
    return np.where(np.isfinite(d), d, np.inf)


def _refine(h: np.ndarray, src: np.ndarray, dst: np.ndarray, huber_m: float | None,
            *, affine: bool = False):
    """Least squares on the error in the plane (Huber loss when `huber_m` is given), from h;
    `affine` keeps the last row (0, 0, 1)."""
    n = 6 if affine else 8

    def matrix(p):
        return np.append(p, [0.0, 0.0, 1.0][n - 6:]).reshape(3, 3)

    def residuals(p):
        return (apply(matrix(p), src) - dst).ravel()

    result = least_squares(residuals, h.ravel()[:n], method="trf",
                           loss="huber" if huber_m else "linear",
                           f_scale=huber_m if huber_m else 1.0, x_scale="jac")
    refined = matrix(result.x)
    return refined if np.all(np.isfinite(refined)) else h


def _checked(h, src, dst, inliers, method, max_residual_mm, *, exact=False) -> Homography:
    distances_mm = 1000.0 * _distances(h, src, dst)
    rms = float(np.sqrt(np.mean(distances_mm**2)))
    worst = float(distances_mm.max())
    check_range("max_residual_mm", max_residual_mm, 0.0, np.inf, "mm")
    if not np.isfinite(rms) or rms > max_residual_mm:
        shown = "unbounded" if not np.isfinite(rms) else f"{rms:.1f} mm"
        raise PoorFitError(
            f"the camera fit is too poor to use: its residual in the table plane is {shown} "
            f"RMS (limit {max_residual_mm:g} mm). Check the camera did not move during the "
            "trial and sees the whole workspace from above, or calibrate from four marked "
            "points")
    return Homography(h, 0.0 if exact else rms, 0.0 if exact else worst, inliers, method,
                      exact)


def refine_with_lengths(
    fit: Homography,
    wrist_px,
    handle_m,
    shoulder_px,
    elbow_px,
    upper_arm_m: float,
    forearm_m: float,
    *,
    max_residual_mm: float = DEFAULT_MAX_RESIDUAL_MM,
) -> Homography:
    """Refine a handle fit with what is known of the arm beyond the handle's patch: in the
    plane the elbow lies `forearm_m` from the handle and the shoulder `upper_arm_m` from the
    elbow (the subject's measured segments, eq. 3.16). The handle alone fixes the map only
    where the handle went; these tie it down where the elbow and the shoulder are, without
    assuming where the shoulder is (so its drift stays measurable). Projective least
    squares with a Huber loss over the handle's inliers and every frame with a visible
    shoulder and elbow; the residual reported is still the handle's, in mm."""
    wrist = np.asarray(wrist_px, dtype=float)
    handle = np.asarray(handle_m, dtype=float)
    shoulder = np.asarray(shoulder_px, dtype=float)
    elbow = np.asarray(elbow_px, dtype=float)
    inl = fit.inliers & np.isfinite(wrist).all(axis=1) & np.isfinite(handle).all(axis=1)
    fore = np.isfinite(elbow).all(axis=1) & np.isfinite(handle).all(axis=1)
    upper = np.isfinite(elbow).all(axis=1) & np.isfinite(shoulder).all(axis=1)
    if fore.sum() < MIN_PAIRS or upper.sum() < MIN_PAIRS:
        return fit
    src, dst = wrist[inl], handle[inl]
    huber = DEFAULT_INLIER_MM / 3000.0

    def residuals(p):
        h = np.append(p, 1.0).reshape(3, 3)
        e_fore = apply(h, elbow[fore])
        e_up = apply(h, elbow[upper])
        s_up = apply(h, shoulder[upper])
        return np.concatenate((
            (apply(h, src) - dst).ravel(),
            np.linalg.norm(e_fore - handle[fore], axis=1) - forearm_m,
            np.linalg.norm(s_up - e_up, axis=1) - upper_arm_m,
        ))

    result = least_squares(residuals, fit.matrix.ravel()[:8], method="trf", loss="huber",
                           f_scale=huber, x_scale="jac")
    h = np.append(result.x, 1.0).reshape(3, 3)
    if not np.all(np.isfinite(h)):
        return fit
    distances = _distances(h, wrist, handle)
    inliers = fit.inliers & (distances < DEFAULT_INLIER_MM / 1000.0)
    src_ok = np.isfinite(distances) & inliers
    return _checked(h, wrist[src_ok], handle[src_ok], inliers, fit.method + "+arm",
                    max_residual_mm)
