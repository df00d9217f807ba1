"""Which samples the plots draw, without Qt: the within/outside split, merged flicker,
thinned paths."""

from __future__ import annotations

import numpy as np

from ui.views import samples
from ui.views.samples import MAX_PATH_POINTS, split_by_mask, xy_step


def test_merge_short_runs_only_flips_short_runs():
    mask = np.array([1] * 30 + [0] * 3 + [1] * 30 + [0] * 40 + [1] * 2, dtype=bool)
    merged = samples.merge_short_runs(mask, 10)
    expected = np.array([1] * 63 + [0] * 42, dtype=bool)
    np.testing.assert_array_equal(merged, expected)
    np.testing.assert_array_equal(samples.merge_short_runs(mask, 1), mask)


def test_short_runs_at_the_start_take_the_first_long_run_and_all_short_the_longest():
    mask = np.array([0] * 2 + [1] * 20 + [0] * 3, dtype=bool)
    np.testing.assert_array_equal(samples.merge_short_runs(mask, 5), np.ones(25, dtype=bool))
    flicker = np.array([1, 0, 0, 1, 0, 0, 0], dtype=bool)
    np.testing.assert_array_equal(samples.merge_short_runs(flicker, 10), np.zeros(7, bool))
    assert samples.merge_short_runs(np.array([], dtype=bool), 3).size == 0


def test_the_two_lines_share_the_sample_after_each_change():
    values = np.arange(6.0)
    mask = np.array([1, 1, 0, 0, 1, 1], dtype=bool)
    inside, outside = split_by_mask(values, mask)
    np.testing.assert_array_equal(inside, [0, 1, 2, np.nan, 4, 5])
    np.testing.assert_array_equal(outside, [np.nan, np.nan, 2, 3, 4, np.nan])
    # Every sample is drawn by at least one line.
    assert not np.any(np.isnan(inside) & np.isnan(outside))


def test_a_long_path_is_thinned_below_the_limit_and_a_short_one_kept():
    assert xy_step(10) == 1
    assert xy_step(MAX_PATH_POINTS) == 1
    assert xy_step(MAX_PATH_POINTS + 1) == 2
    for n in (12_345, 200_000):
        assert len(range(0, n, xy_step(n))) <= MAX_PATH_POINTS
