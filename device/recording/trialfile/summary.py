"""The summary a trial file's writer computes at close from its samples (docs/data-format.md,
`/summary`): counts, duration, first and last tick, the ticks missing, and the loop's
timing statistics, each channel read SUMMARY_BLOCK samples at a time."""

from __future__ import annotations

import math

import h5py
import numpy as np

from core.blockwise import percentiles_of_blocks

SUMMARY_BLOCK = 100_000
"""Samples of a timing channel read at once: a 100 × 120 s trial's channel is 6 million."""


def computed_summary(f: h5py.File, n: int, n_events: int) -> dict:
    """The writer's own summary of the file's first `n` samples and `n_events` events."""
    period = float(f.attrs["sample_period_s"])
    summary: dict = {
        "n_samples": np.int64(n),
        "n_events": np.int64(n_events),
        "duration_s": n * period,
    }
    series = f["timeseries"]
    if n and "tick" in series:
        first, last = int(series["tick"][0]), int(series["tick"][n - 1])
        summary["first_tick"] = np.int64(first)
        summary["last_tick"] = np.int64(last)
        summary["ticks_missing"] = np.int64(max(0, last - first + 1 - n))
    for name in ("lateness", "compute_time"):
        if not n or name not in series:
            continue
        summary.update(timing_summary(name, series[name], n, period))
    return summary


def timing_summary(name: str, channel: h5py.Dataset, n: int, period: float) -> dict:
    """A timing channel's mean, p50, p99 and max over its finite samples (and, for the
    lateness, the share of ticks a whole period late)."""

    def blocks():
        for first in range(0, n, SUMMARY_BLOCK):
            values = channel[first:min(n, first + SUMMARY_BLOCK)]
            yield values[np.isfinite(values)]

    count = total = late = 0
    worst = -math.inf
    for values in blocks():
        if len(values):
            count += len(values)
            total += float(np.sum(values, dtype=np.float64))
            worst = max(worst, float(values.max()))
            late += int(np.count_nonzero(values.astype(np.float64) >= period))
    if count == 0:
        return {}
    p50, p99 = percentiles_of_blocks(blocks, count, (50, 99))
    out = {f"{name}_mean_s": total / count, f"{name}_p50_s": p50, f"{name}_p99_s": p99,
           f"{name}_max_s": worst}
    if name == "lateness":
        # A tick that starts a whole period late has missed its deadline.
        out["late_fraction"] = late / count
    return out
