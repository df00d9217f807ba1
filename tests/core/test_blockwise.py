"""A long recording's figures a block at a time (core.blockwise) against the whole-array
ones (core.metrics, the reference), on synthetic signals: a hand going round a circle
with a tremor and sensor noise."""

import math

import numpy as np
import pytest

from core import smoothness
from core.blockwise import MARGIN_PERIODS, _median, compute_metrics_blockwise
from core.errors import ParameterError
from core.metrics import compute_metrics
from core.smoothness import sparc, sparc_of_blocks

DT = 0.002
N = 12_001
RTOL = 1e-9


def recording(n=N):
    rng = np.random.default_rng(3)
    t = np.arange(n) * DT
    phase = 2 * math.pi * 0.25 * t + 0.3 * np.sin(2 * math.pi * 0.1 * t)
    desired = np.column_stack((0.1 * np.cos(2 * math.pi * 0.25 * t),
                               0.1 * np.sin(2 * math.pi * 0.25 * t)))
    position = np.column_stack((0.1 * np.cos(phase), 0.1 * np.sin(phase)))
    position += 0.002 * np.sin(2 * math.pi * 5 * t)[:, None] + rng.normal(0, 1e-4, (n, 2))
    direction = np.column_stack((-np.sin(2 * math.pi * 0.25 * t),
                                 np.cos(2 * math.pi * 0.25 * t)))
    force = 2.0 * direction + rng.normal(0, 1.0, (n, 2))
    return {"t_s": t, "position_m": position, "desired_position_m": desired,
            "desired_direction": direction, "force_N": force,
            "isb_angles_rad": np.column_stack((np.sin(phase), 0.5 * np.cos(phase))),
            "torque_Nm": rng.normal(0, 0.3, (n, 2)) + np.sin(phase)[:, None],
            "robot_torque_Nm": rng.normal(0, 0.2, (n, 2)),
            "robot_angle_rad": np.column_stack((phase, 0.5 * phase)),
            "robot_own_torque_Nm": rng.normal(0, 0.1, (n, 2)),
            "help_torque_Nm": np.where(rng.random((n, 1)) < 0.3, 0.1, 0.0) * np.ones((1, 2))}


@pytest.mark.parametrize("block", [1000, 4999, N])
def test_every_figure_equals_the_whole_arrays(monkeypatch, block):
    monkeypatch.setattr(smoothness, "FOLD", 2048)  # the spectrum in several passes
    data = recording()
    whole = compute_metrics(data["t_s"], data["position_m"],
                            **{k: v for k, v in data.items() if k not in ("t_s", "position_m")})
    asked = []

    def read(role, first, stop):
        asked.append(stop - first)
        return data[role][first:stop]

    blocks = compute_metrics_blockwise(read, N, list(data), block=block)
    a, b = blocks.to_dict(), whole.to_dict()
    for name in b:
        np.testing.assert_allclose(a[name], b[name], rtol=RTOL, atol=0.0, err_msg=name)
    assert a["directional_performance_pct"] == b["directional_performance_pct"]  # same sums
    assert blocks.within_intervals_s == ()  # not kept (module notes)
    # the low-pass's margin each side (rounded up from the median step, a hair off DT)
    margin = math.ceil(MARGIN_PERIODS / (10.0 * DT)) + 1
    assert max(asked) <= block + 2 * margin + 2


def test_a_channel_left_out_leaves_its_figures_nan():
    data = recording(3000)
    blocks = compute_metrics_blockwise(lambda role, a, b: data[role][a:b], 3000, [],
                                       block=700)
    assert math.isnan(blocks.rmse_x_m)
    assert math.isnan(blocks.robot_work_J)
    assert math.isnan(blocks.led_pct)
    assert math.isfinite(blocks.sparc)


def test_the_spectrum_folded_pass_by_pass_is_sparcs():
    speed = np.abs(np.sin(2 * math.pi * 0.3 * np.arange(30_000) * DT)) + 0.05
    for fold, size in ((1 << 19, 30_000), (4096, 777)):
        def blocks(size=size):
            return (speed[a:a + size] for a in range(0, 30_000, size))

        value = sparc_of_blocks(blocks, 30_000, DT, fold=fold)
        assert value == pytest.approx(sparc(speed, DT), rel=1e-12)
    with pytest.raises(ParameterError, match="speed"):
        sparc_of_blocks(lambda: iter([-speed]), 30_000, DT)


def test_the_median_step_from_counts_is_numpys():
    for values in ([0.002] * 5 + [0.0020000000000000018] * 4, [1.0, 2.0], [3.0, 1.0, 2.0],
                   [1.0] * 3 + [2.0] * 3):
        counts = {}
        for v in values:
            counts[v] = counts.get(v, 0) + 1
        assert _median(counts) == np.median(values)


def test_a_gap_or_a_step_back_in_time_is_refused_as_the_whole_arrays_would():
    data = recording(3000)
    t = data["t_s"].copy()
    t[2500:] += 1.0

    def read(role, a, b):
        return (t if role == "t_s" else data[role])[a:b]

    with pytest.raises(ParameterError, match=r"a gap of 1\.002 s after sample 2499"):
        compute_metrics_blockwise(read, 3000, [], block=700)
    t = data["t_s"].copy()
    t[1400] = t[1399]
    with pytest.raises(ParameterError, match="not increasing at sample 1400"):
        compute_metrics_blockwise(read, 3000, [], block=700)


def test_percentiles_of_a_series_read_in_blocks_are_numpys():
    """The trial file's timing summary (p50, p99 of 6 million samples) without holding them:
    the same values as np.percentile, bit for bit, float32 and float64."""
    from core.blockwise import percentiles_of_blocks

    rng = np.random.default_rng(0)
    for dtype in (np.float32, np.float64):
        for n in (1, 2, 1000, 30_001):
            values = (rng.normal(0, 1e-4, n) ** 3).astype(dtype)
            values[: n // 3] = 0.0

            def blocks(values=values, n=n):
                return (values[a:a + 997] for a in range(0, n, 997))

            percents = (50, 99, 0, 100, 37.5)
            assert percentiles_of_blocks(blocks, n, percents) == [
                float(np.percentile(values.astype(np.float64), q)) for q in percents]
