"""Joint angles from keypoints in the table plane, in the arm's own convention, and the
shoulder the equation solver assumes still.

Convention (core.arm, eq. 3.16): θ_s and θ_e are absolute angles in the global frame and
the segments point from the shoulder S towards the hand along −e(θ), so

    S − E = l_u e(θ_s)            θ_s = atan2(S_y − E_y, S_x − E_x)
    E − W = l_f e(θ_e)            θ_e = θ_s + wrap(atan2(E_y − W_y, E_x − W_x) − θ_s)

with the relative angle θ_e − θ_s taken in (−π, π], the branch the solver's
`core.arm_terms.ik_of` gives (0 to π for a flexed right elbow), so both read the same
numbers for the same posture. The ISB display angles (eq. 3.37–3.38) are the arm's own
`ArmModel.isb_angles`. Segment lengths are not used: the camera measures directions.

The equation solver (eq. 3.28) assumes the shoulder does not move. `shoulder_drift` measures
how far the camera saw it move, and `solver_angles_with_shoulder` reruns the solver with the
camera's shoulder track instead of the fixed shoulder.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.arm import ArmModel
from core.errors import ParameterError, check_positive
from core.pose.keypoints import ELBOW, SHOULDER, WRIST

# What the thesis asked of the subject (section 3.6: "keeping their shoulder as still as
# possible"); a therapist sets their own. 3 cm moves the elbow angle about 3–6° at 0.3 m.
DEFAULT_DRIFT_LIMIT_M = 0.03
# The shoulder's start position: the median over this first stretch of the track.
DRIFT_REFERENCE_S = 1.0


def wrap(angle):
    """Angles into (−π, π]."""
    angle = np.asarray(angle, dtype=float)
    return np.pi - np.mod(np.pi - angle, 2.0 * np.pi)


def arm_angles(keypoints_m) -> np.ndarray:
    """(θ_s, θ_e) (..., 2) in rad from table-plane keypoints (..., ≥3, 2) in the order of
    core.pose.keypoints (shoulder, elbow, wrist). A gap in any of the three is a gap in
    both angles (the shoulder angle needs S and E, the elbow's all three)."""
    k = np.asarray(keypoints_m, dtype=float)
    if k.ndim < 2 or k.shape[-2] < 3 or k.shape[-1] != 2:
        raise ParameterError("keypoints_m", k.shape, "(..., 3 or 4, 2): shoulder, elbow, wrist")
    s, e, w = k[..., SHOULDER, :], k[..., ELBOW, :], k[..., WRIST, :]
    upper = s - e
    fore = e - w
    ts = np.arctan2(upper[..., 1], upper[..., 0])
    te = ts + wrap(np.arctan2(fore[..., 1], fore[..., 0]) - ts)
    bad = ~np.isfinite(k[..., :3, :]).all(axis=(-1, -2))
    ts = np.where(bad, np.nan, ts)
    te = np.where(bad, np.nan, te)
    return np.stack((ts, te), axis=-1)


def isb_angles(arm: ArmModel, theta) -> np.ndarray:
    """ISB display angles (..., 2) of absolute angles (..., 2), eq. 3.37–3.38; NaN stays."""
    return arm.isb_angles(theta)


@dataclass(frozen=True, slots=True)
class ShoulderDrift:
    """How the camera's shoulder moved over a trial (all in m, global frame).

    `start_m`: where it was at the start (median of the first second seen); `drift_m` (N,):
    distance from there at each sample (NaN in gaps); `max_drift_m`, `rms_drift_m`;
    `offset_m`: distance of the track's median from the shoulder the solver assumed
    (`assumed_m`), which is a setup error rather than movement; `limit_m`: the therapist's
    limit; `exceeded`: the drift went past it; `time_over_s`: for how long."""

    start_m: np.ndarray
    drift_m: np.ndarray
    max_drift_m: float
    rms_drift_m: float
    assumed_m: np.ndarray
    offset_m: float
    limit_m: float
    exceeded: bool
    time_over_s: float

    def warning(self) -> str | None:
        """One line for the therapist when the shoulder moved past the limit, else None."""
        if not self.exceeded:
            return None
        return (f"the shoulder moved up to {100 * self.max_drift_m:.1f} cm during the trial "
                f"(limit {100 * self.limit_m:.1f} cm, over it for {self.time_over_s:.1f} s); "
                "the equation solver's angles assume it still: compare with the solver run "
                "on the camera's shoulder track")


def shoulder_drift(
    time_s,
    shoulder_m,
    assumed_m,
    *,
    limit_m: float = DEFAULT_DRIFT_LIMIT_M,
) -> ShoulderDrift:
    """The drift of a shoulder track (N, 2) m sampled at `time_s` (N,), gaps as NaN,
    against its own start and against the shoulder the solver assumed (2,)."""
    check_positive("limit_m", limit_m, "m")
    t = np.asarray(time_s, dtype=float)
    track = np.asarray(shoulder_m, dtype=float)
    assumed = np.asarray(assumed_m, dtype=float).reshape(2)
    if track.shape != (t.size, 2):
        raise ParameterError("shoulder_m", track.shape, f"({t.size}, 2): one point per time")
    seen = np.isfinite(track).all(axis=1) & np.isfinite(t)
    if not seen.any():
        raise ParameterError("shoulder_m", "all gaps",
                             "a shoulder seen by the camera at least once")
    first = t[seen][0]
    early = seen & (t <= first + DRIFT_REFERENCE_S)
    start = np.median(track[early], axis=0)
    drift = np.linalg.norm(track - start, axis=1)
    over = seen & (drift > limit_m)
    dt = np.diff(t, append=t[-1])
    if t.size > 1:
        dt[-1] = np.median(np.diff(t))
    return ShoulderDrift(
        start_m=start, drift_m=drift,
        max_drift_m=float(np.nanmax(drift)),
        rms_drift_m=float(np.sqrt(np.nanmean(drift**2))),
        assumed_m=assumed,
        offset_m=float(np.linalg.norm(np.median(track[seen], axis=0) - assumed)),
        limit_m=float(limit_m),
        exceeded=bool(over.any()),
        time_over_s=float(np.sum(dt[over])),
    )


def solver_angles_with_shoulder(arm: ArmModel, hand_m, shoulder_m) -> np.ndarray:
    """The equation solver (eq. 3.28, the arm's own `ik_terms`) with a moving shoulder:
    the hand (N, 2) and the shoulder (N, 2) at the same samples, m. The solver depends only
    on the hand relative to the shoulder, so the hand is shifted by the shoulder's offset
    from the arm's fixed one. Gaps and unreachable points give NaN."""
    hand = np.asarray(hand_m, dtype=float)
    track = np.asarray(shoulder_m, dtype=float)
    if hand.shape != track.shape or hand.shape[-1] != 2:
        raise ParameterError("shoulder_m", track.shape, f"{hand.shape}: one per hand position")
    shift = track - np.array([arm.shoulder_x_m, arm.shoulder_y_m])
    relative = hand - shift
    return np.stack(arm.ik_terms(relative[..., 0], relative[..., 1]), axis=-1)
