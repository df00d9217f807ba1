"""Video frames onto the trial's clock, and the 30 fps series onto its 2 ms samples.

Alignment. Every frame is stamped with time.monotonic() when it was read
(device.camera.capture), and the loop records each sample's `wall_time`, the monotonic
time it read the sensors, from an origin it stores in the trial's summary
(`wall_time_origin_monotonic_s`). A frame's place on the trial's clock is therefore its
stamp minus the origin, read through the samples' (wall_time → time) relation, so that a
late tick or a simulated trial that ran faster than real time still lines up sample for
sample. Before the first or after the last sample the relation is continued with the
slope of one second per second.

Interpolation (Appendix A.5.1: 1-D interpolation to the robot's 2 ms rate). Linear
between the two frames around each sample, and only where both are there: a sample
whose neighbouring frames include a gap (a keypoint not seen, a frame dropped: more than
`max_gap_s` between them) or that lies outside the video stays NaN. Angles are unwrapped
along the finite frames first, so a shoulder near ±180° does not interpolate through 0.
"""

from __future__ import annotations

import numpy as np

from core.errors import ParameterError, check_positive

# Frames further apart than this many frame periods have a dropped frame between them;
# nothing is interpolated across it.
MAX_GAP_PERIODS = 1.5


def frame_times(frame_monotonic_s, origin_monotonic_s: float, wall_time_s, time_s) -> np.ndarray:
    """Each frame's time on the trial's clock (s, the `time` channel's), from its monotonic
    stamp, the trial's wall-time origin and the samples' `wall_time` and `time` (N,)."""
    stamps = np.asarray(frame_monotonic_s, dtype=float)
    wall = np.asarray(wall_time_s, dtype=float)
    t = np.asarray(time_s, dtype=float)
    if wall.shape != t.shape or wall.ndim != 1 or wall.size < 2:
        raise ParameterError("wall_time_s", wall.shape,
                             "(N,) with N ≥ 2, one wall time per sample time")
    keep = np.isfinite(wall) & np.isfinite(t)
    wall, t = wall[keep], t[keep]
    if wall.size < 2 or np.any(np.diff(wall) <= 0):
        raise ParameterError("wall_time_s", "not increasing",
                             "monotonic wall times that only increase")
    since = stamps - float(origin_monotonic_s)
    mapped = np.interp(since, wall, t)
    before = since < wall[0]
    after = since > wall[-1]
    mapped[before] = t[0] + (since[before] - wall[0])
    mapped[after] = t[-1] + (since[after] - wall[-1])
    return mapped


def frame_period(frame_t_s) -> float:
    """The median step between frames, s."""
    t = np.asarray(frame_t_s, dtype=float)
    steps = np.diff(t[np.isfinite(t)])
    if steps.size == 0 or np.any(steps <= 0):
        raise ParameterError("frame_t_s", "fewer than 2 frames, or not increasing",
                             "at least 2 frames with increasing times")
    return float(np.median(steps))


def resample(frame_t_s, values, sample_t_s, *, max_gap_s: float | None = None,
             angles: bool = False) -> np.ndarray:
    """Values at frame times (F,) or (F, k) linearly onto sample times (N,), gaps kept.

    A sample gets a value only when the frames just before and after it (or one at the
    same instant) are finite and at most `max_gap_s` apart (default MAX_GAP_PERIODS frame
    periods). `angles`: unwrap each column along its finite frames first."""
    ft = np.asarray(frame_t_s, dtype=float)
    st = np.asarray(sample_t_s, dtype=float)
    v = np.array(values, dtype=float)
    single = v.ndim == 1
    if single:
        v = v[:, None]
    if v.shape[0] != ft.size or ft.ndim != 1:
        raise ParameterError("values", v.shape, f"({ft.size}, …): one row per frame time")
    if ft.size < 2:
        raise ParameterError("frame_t_s", f"{ft.size} frames", "at least 2 frames")
    if np.any(np.diff(ft) <= 0) or not np.isfinite(ft).all():
        raise ParameterError("frame_t_s", "not increasing", "finite frame times that increase")
    gap = MAX_GAP_PERIODS * frame_period(ft) if max_gap_s is None else max_gap_s
    check_positive("max_gap_s", gap, "s")
    if angles:
        for j in range(v.shape[1]):
            finite = np.isfinite(v[:, j])
            v[finite, j] = np.unwrap(v[finite, j])
    out = np.full((st.size, v.shape[1]), np.nan)
    right = np.searchsorted(ft, st, side="left")  # ft[right-1] < st <= ft[right]
    inside = (right < ft.size) & (st >= ft[0])
    exact = inside & (ft[np.minimum(right, ft.size - 1)] == st)
    out[exact] = v[right[exact]]
    between = inside & ~exact & (right > 0)
    i1 = right[between]
    i0 = i1 - 1
    span = ft[i1] - ft[i0]
    w = ((st[between] - ft[i0]) / span)[:, None]
    mixed = (1.0 - w) * v[i0] + w * v[i1]
    mixed[span > gap] = np.nan  # NaN in either frame is NaN already
    out[between] = mixed
    return out[:, 0] if single else out


def covered_span(frame_t_s, sample_t_s) -> tuple[float, float]:
    """How much of the samples' span the frames miss at its start and at its end, s
    (0 when the video starts before the first sample or ends after the last)."""
    ft = np.asarray(frame_t_s, dtype=float)
    st = np.asarray(sample_t_s, dtype=float)
    return (max(0.0, float(ft[0] - st[0])), max(0.0, float(st[-1] - ft[-1])))
