"""Which samples the plots draw: a signal split into its within and outside lines, the
short runs of a flickering mask merged, and a long path thinned.

These choose what to draw and never change a figure: the big numbers come from
every sample (ui.views.trialview).
"""

from __future__ import annotations

import numpy as np

# Runs of within/outside shorter than this are merged into their neighbour for
# display only: at 500 Hz a 20 ms flicker is invisible as a colour but doubles
# the number of line segments drawn.
MERGE_RUNS_S = 0.05

# A path drawn with more points than this is thinned: at 500 Hz a hand moves well under
# a pixel between samples, and every point costs paint time at 60 Hz.
MAX_PATH_POINTS = 5000


def xy_step(n: int) -> int:
    """Stride that keeps a path of n samples under MAX_PATH_POINTS."""
    return max(1, -(-n // MAX_PATH_POINTS))


def merge_short_runs(mask: np.ndarray, min_samples: int) -> np.ndarray:
    """A copy of a boolean mask where runs shorter than `min_samples` take the value of
    the run before them (the first runs, of the run after)."""
    mask = np.asarray(mask, dtype=bool)
    if mask.size == 0 or min_samples <= 1:
        return mask.copy()
    change = np.flatnonzero(mask[1:] != mask[:-1]) + 1
    starts = np.concatenate(([0], change))
    lengths = np.diff(np.concatenate((starts, [mask.size])))
    values = mask[starts]
    long = lengths >= min_samples
    if not long.any():
        return np.full(mask.size, values[np.argmax(lengths)])
    # Each short run takes the value of the nearest long run before it.
    index = np.where(long, np.arange(values.size), -1)
    np.maximum.accumulate(index, out=index)
    first_long = int(np.argmax(long))
    index[index < 0] = first_long
    return np.repeat(values[index], lengths)


def split_by_mask(values: np.ndarray, mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(inside, outside): copies of `values` with NaN where the other one draws. The
    sample after each change is drawn by both, so the two lines meet."""
    previous = np.empty_like(mask)
    if mask.size:
        previous[0] = mask[0]
        previous[1:] = mask[:-1]
    inside = np.where(mask | previous, values, np.nan)
    outside = np.where(~mask | ~previous, values, np.nan)
    return inside, outside
