"""EMG channels read from one file, put on one time base.

A Trigno Discover collection can hold sensors at different EMG rates: Trigno Avanti EMG at
1259.2593 Hz or 1925.9259 Hz and Quattro EMG at 2222.2222 Hz in one export (the Trigno
Discover 1.7.0 file in praneethnamburi/delsys tests/fixtures/discover170.csv). The trial
file keeps one EMG rate, so every EMG channel slower than the fastest is brought to the
fastest EMG rate by polyphase resampling (scipy.signal.resample_poly: zero-stuffing by
`up`, a Kaiser-windowed FIR low-pass at the lower of the two Nyquist frequencies — the
anti-alias (and anti-imaging) filter — and keeping every `down`-th sample), and the import
says so in a note. Trigno rates are whole multiples of 1/13.5 ms (the base's frame), so
their ratios are ratios of small whole numbers (2222.2222/1259.2593 = 30/17); rates that
are not are refused in one line. Nothing is ever resampled down: the fastest rate is
kept, so no channel loses bandwidth.
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction

import numpy as np
from scipy.signal import resample_poly

from device.emg.emgtext import EmgData, EmgFileError, Text, check_range

MAX_DENOMINATOR = 1000
RATE_TOLERANCE = 1e-4  # relative: rates read from printed time stamps
PRINTED_DIGITS = 7
"""EMGworks prints its times with 7 significant digits (`0.0007941176`, `0.01032353` in a
real export: neuromechanist/emgio examples/truncated_trigno_sample.csv): from 1000 s on
a time is printed to the millisecond, coarser than a Trigno EMG sample (0.79 ms at
1259 Hz), so consecutive samples print the same time."""
DRIFT_PERIODS = 0.1  # how far, in sample periods, a declared rate may drift from the times
TRIGNO_FRAME_S = 0.0135  # a Trigno base's frame: its rates are whole multiples of 1/frame


def trigno_rate(rate_hz: float) -> float:
    """The Trigno rate (a whole multiple of 1 / TRIGNO_FRAME_S) nearest `rate_hz`: the
    rate of a file that names none, measured from times printed too coarsely to give it
    exactly."""
    return max(1, round(rate_hz * TRIGNO_FRAME_S)) / TRIGNO_FRAME_S


def printed_grid(t: np.ndarray, rate_hz: float) -> np.ndarray | None:
    """The times of samples at `rate_hz` from the first, when the printed times `t` are
    those times rounded to PRINTED_DIGITS significant digits (each within one of its last
    digits, the first's rounding included, and DRIFT_PERIODS); else None (a gap, another
    rate: the caller judges the printed times themselves)."""
    t = np.asarray(t, dtype=float)
    if t.size < 2 or not rate_hz > 0:
        return None
    grid = t[0] + np.arange(t.size) / rate_hz
    size = np.maximum(np.abs(grid), np.finfo(float).tiny)
    digit = 10.0 ** (np.floor(np.log10(size)) - (PRINTED_DIGITS - 1))
    return grid if bool(np.all(np.abs(t - grid) <= digit + DRIFT_PERIODS / rate_hz)) else None


@dataclass(frozen=True, slots=True, eq=False)
class Channel:
    """One EMG channel as the file has it: `volts` (N,) at `rate_hz` from `t0_s`; `t_s`
    (N,) when the file prints a time per sample (else None), `lines` the file line of
    each sample (for refusals)."""

    name: str
    rate_hz: float
    t0_s: float
    volts: np.ndarray
    lines: np.ndarray
    t_s: np.ndarray | None = None
    unit: str = ""  # as the file says it; "" when it says none and volts were taken


def rate_ratio(rate_hz: float, target_hz: float) -> tuple[int, int] | None:
    """(up, down) with rate_hz · up / down = target_hz within RATE_TOLERANCE, or None."""
    try:
        ratio = Fraction(target_hz / rate_hz).limit_denominator(MAX_DENOMINATOR)
    except (OverflowError, ValueError):  # rates 1e300 apart: no ratio at all
        return None
    up, down = ratio.numerator, ratio.denominator
    if abs(rate_hz * up / down - target_hz) > RATE_TOLERANCE * target_hz:
        return None
    return up, down


def combine(text: Text, layout: str, source: str, channels: list[Channel],
            skipped: list[str], notes: list[str] | None = None) -> EmgData:
    """EmgData of `channels` on the fastest channel's time base; `skipped` names the
    channels that are not EMG (one note line); `layout` names the file's layout in every
    refusal ("a Trigno Discover 2.1.0.7 export with a time column per channel")."""
    path = text.path
    notes = [*text.notes, *(notes or [])]
    if skipped:
        notes.insert(0, f"skipped channels that are not EMG: {', '.join(skipped)}")
    if not channels:
        raise EmgFileError(path, f"{layout}: no EMG channel"
                                 + (f" (only {', '.join(skipped)})" if skipped else ""),
                           "export the EMG channels (unit V, mV or µV) too")
    names = [c.name for c in channels]
    if len(set(names)) != len(names):
        twice = sorted({n for n in names if names.count(n) > 1})
        raise EmgFileError(path, f"{layout}: two EMG channels share one label "
                                 f"({', '.join(twice)})", "rename one in the export")
    for c in channels:
        if c.volts.size < 2:
            raise EmgFileError(path, f"{layout}: {c.volts.size} samples of {c.name}",
                               "a recording needs at least two; export it again")
        check_range(path, layout, c.name, c.volts, f"in {c.unit} as the file says" if c.unit
                    else "the export names no unit, so volts were taken")
    top = max(c.rate_hz for c in channels)
    reference = next(c for c in channels if c.rate_hz == top)
    period = 1.0 / top
    for c in channels:
        if abs(c.t0_s - reference.t0_s) > 0.5 / c.rate_hz:
            raise EmgFileError(path, f"{layout}: {c.name} starts at {c.t0_s:g} s, "
                                     f"{reference.name} at {reference.t0_s:g} s",
                               "the EMG channels must start together")
    columns, resampled = [], []
    for c in channels:
        if abs(c.rate_hz - top) <= RATE_TOLERANCE * top:
            columns.append(c.volts)
            continue
        ratio = rate_ratio(c.rate_hz, top)
        if ratio is None:
            raise EmgFileError(path, f"{layout}: the EMG rates {c.rate_hz:g} Hz ({c.name}) and "
                                     f"{top:g} Hz ({reference.name}) are not in a ratio of "
                                     "whole numbers, so the slower cannot be resampled to "
                                     "the faster", "export the EMG at one rate")
        up, down = ratio
        columns.append(resample_poly(c.volts, up, down))
        resampled.append(f"{c.name} {c.rate_hz:g} Hz")
    if resampled:
        notes.append(f"resampled to the fastest EMG rate {top:g} Hz ({reference.name}) with "
                     f"an anti-alias FIR filter (scipy resample_poly): {', '.join(resampled)}")
    n = min(len(v) for v in columns)
    cut = [f"{c.name} ({len(v) - n})" for c, v in zip(channels, columns, strict=True)
           if len(v) > n]
    if cut:
        notes.append(f"samples after the shortest EMG channel's end dropped: {', '.join(cut)}")
    same_clock = [c for c in channels if c.t_s is not None
                  and abs(c.rate_hz - top) <= RATE_TOLERANCE * top]
    if reference.t_s is not None:
        t = reference.t_s[:n]
        for c in same_clock[1:]:
            other = c.t_s[:n]
            differs = np.flatnonzero(np.abs(other - t) > 0.5 * period)
            if differs.size:
                k = int(differs[0])
                raise EmgFileError(path, f"{layout}: line {int(c.lines[k])}: the time of "
                                         f"{c.name} ({other[k]:g} s) differs from that of "
                                         f"{reference.name} ({t[k]:g} s)",
                                   "the EMG channels must share a clock")
        grid = printed_grid(t, top)  # the times printed coarser than a sample, late on
        if grid is not None:
            t = grid
    else:
        t = reference.t0_s + np.arange(n) * period
    step = np.diff(t)
    if (step <= 0).any():
        k = int(np.flatnonzero(step <= 0)[0]) + 1
        raise EmgFileError(path, f"{layout}: the time goes back or stands still at sample {k} "
                                 f"({t[k]:g} s, line {int(reference.lines[k])})",
                           "the file may be two recordings joined")
    samples = np.column_stack([v[:n] for v in columns])
    return EmgData(tuple(names), float(top), np.array(t, dtype=float), samples, source, path,
                   tuple(notes))
