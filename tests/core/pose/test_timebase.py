"""Video frames onto the trial's clock (to within one frame) and the 30 fps series onto the
2 ms samples with gaps kept, against known answers."""

from __future__ import annotations

import numpy as np
import pytest

from core.errors import ParameterError
from core.pose.timebase import covered_span, frame_times, resample

PERIOD = 0.002
FPS = 30.0


def test_frames_line_up_with_the_samples_to_within_one_frame():
    """A live trial: ticks that run late now and then (wall_time ≠ time), a camera that
    started 0.4 s before the trial with jitter in its stamps and a dropped frame; each
    frame's trial time must match the instant it was taken on the trial's clock."""
    rng = np.random.default_rng(2)
    n = 15000  # 30 s
    time_s = np.arange(n) * PERIOD
    lateness = np.abs(rng.normal(0, 0.0002, n))
    lateness[5000:5011] += 0.020 - 0.0018 * np.arange(11)  # a 20 ms stall, caught up
    wall = time_s + lateness
    origin = 18234.5  # time.monotonic() when the loop started the trial
    taken = np.arange(-0.4, 30.4, 1 / FPS)  # true trial times of the frames
    taken = np.delete(taken, 300)  # dropped
    stamps = origin + taken + rng.normal(0, 0.002, taken.size)  # read a little late or early
    mapped = frame_times(stamps, origin, wall, time_s)
    assert np.abs(mapped - taken).max() < 1 / FPS
    assert np.abs(mapped - taken).max() < 0.03
    assert mapped[0] == pytest.approx(-0.4, abs=0.01)  # before the first sample: slope 1
    # the same for a trial simulated 20× faster than real time: wall_time runs slower
    wall_fast = time_s / 20.0
    stamps_fast = origin + taken / 20.0
    mapped = frame_times(stamps_fast, origin, wall_fast, time_s)
    inside = (taken >= 0) & (taken <= time_s[-1])
    assert np.allclose(mapped[inside], taken[inside], atol=1e-9)


def test_alignment_refuses_wall_times_that_go_back():
    with pytest.raises(ParameterError, match="increasing"):
        frame_times([1.0], 0.0, [0.0, 0.002, 0.001], [0.0, 0.002, 0.004])
    with pytest.raises(ParameterError):
        frame_times([1.0], 0.0, [0.0], [0.0])


def test_a_linear_motion_is_resampled_exactly_and_gaps_stay_gaps():
    frames = np.arange(0, 10, 1 / FPS)
    values = np.column_stack((2.0 * frames + 1.0, -frames))
    values[60] = np.nan  # a keypoint not seen in frame 60
    dropped = np.ones(frames.size, bool)
    dropped[150:153] = False  # three frames dropped
    frames_kept, values_kept = frames[dropped], values[dropped]
    samples = np.arange(-0.5, 10.5, PERIOD)
    out = resample(frames_kept, values_kept, samples)
    truth = np.column_stack((2.0 * samples + 1.0, -samples))
    finite = np.isfinite(out).all(axis=1)
    assert np.allclose(out[finite], truth[finite], atol=1e-9)
    # gaps: before and after the video, around frame 60, across the dropped frames
    assert not finite[samples < 0].any()
    assert not finite[samples > frames[-1] + 1e-9].any()
    around_60 = (samples > frames[59]) & (samples < frames[61])
    assert not finite[around_60].any()
    across = (samples > frames[149]) & (samples < frames[153])
    assert not finite[across].any()
    # and nothing else is a gap
    assert finite.sum() == (~(samples < 0) & ~(samples > frames[-1] + 1e-9)
                            & ~around_60 & ~across).sum()
    # exactly at a frame's time the frame's own value
    at = resample(frames, values[:, 0], frames[[10, 20]])
    assert np.allclose(at, values[[10, 20], 0])


def test_angles_near_a_half_turn_do_not_interpolate_through_zero():
    frames = np.array([0.0, 1 / FPS])
    angles = np.array([np.pi - 0.01, -np.pi + 0.01])  # 0.02 rad apart across ±π
    mid = resample(frames, angles, [0.5 / FPS], angles=True)
    assert abs(abs(mid[0]) - np.pi) < 1e-9
    plain = resample(frames, angles, [0.5 / FPS])
    assert abs(plain[0]) < 1e-9  # what unwrapping is for


def test_resampling_refuses_what_it_cannot_use():
    with pytest.raises(ParameterError, match="one row per frame"):
        resample([0.0, 0.1], np.zeros(3), [0.05])
    with pytest.raises(ParameterError, match="at least 2 frames"):
        resample([0.0], np.zeros(1), [0.05])
    with pytest.raises(ParameterError, match="increas"):
        resample([0.1, 0.0], np.zeros(2), [0.05])


def test_the_span_the_video_misses():
    assert covered_span([0.5, 9.0], [0.0, 10.0]) == (0.5, 1.0)
    assert covered_span([-1.0, 11.0], [0.0, 10.0]) == (0.0, 0.0)
