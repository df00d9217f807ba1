"""A long trial's figures a block of samples at a time: `core.metrics.compute_metrics`'
definitions and numbers (to rounding), holding a block's worth of each channel however
long the trial (issue 13 #21: a 100 × 120 s trial is 6 million samples, and its SPARC a
2²⁷-point spectrum).

The samples come from `read(role, first, stop)`, the roles being `compute_metrics`'
argument names ("t_s", "position_m", "force_N", …); `given` names the roles there are
(each finite). Each figure is the same formula on the same samples; what differs, and why
it is still the same figure:

* sums (the RMSE, the path lengths, the work, the correlation's moments) add the same
  terms block by block, in another order: they differ by rounding;
* the zero-lag low-pass (core.signal.lowpass) of a block is the low-pass of the block with
  MARGIN_PERIODS cutoff periods of samples on either side, whose start-up transient has
  died out inside the margin (e^−72 of it at the 4th order's slowest pole); at the trial's
  two ends the block is padded as the whole trial is. The speed's derivative is taken on
  the same stretch, so the block's central differences see their true neighbours;
* SPARC's spectrum is accumulated without the speed in memory
  (core.smoothness.sparc_of_blocks), from the speed written to a temporary file;
* Fig. 3.9's intervals are not kept: a trial has as many as its force switches in and
  out of the cone (possibly millions), the trial file stores none (a viewer finds them
  from the samples), and the percentage does not need them. `within_intervals_s` and
  `outside_intervals_s` are empty; the time within is summed in the same order as
  `directional_performance` does, so the percentage is the same bit for bit.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Callable, Iterator, Sequence

import numpy as np

from core.errors import ParameterError
from core.metrics import (
    DEFAULT_FILTER_ORDER,
    DEFAULT_MIN_FORCE_N,
    DEFAULT_SPEED_CUTOFF_HZ,
    DEFAULT_TOLERANCE_RAD,
    DEFAULT_TORQUE_CUTOFF_HZ,
    TrialMetrics,
    _cross,
    assemble,
    checked_options,
    force_within,
)
from core.reaches import (
    DEFAULT_INITIAL_WINDOW_S,
    DEFAULT_MIN_PEAK_SPEED_M_S,
    DEFAULT_ONSET_FRACTION,
    Reach,
    reach_metrics,
)
from core.signal import MAX_GAP_RATIO, lowpass, second_difference
from core.smoothness import ldlj_value, sparc_of_blocks
from core.work import MechanicalWork, helped_samples, work_shares, work_terms

Read = Callable[[str, int, int], np.ndarray]
"""Samples first…stop−1 of a role (a `compute_metrics` argument name) of the trial."""
BLOCK = 50_000
"""Samples of a channel held at once (100 s at 2 ms)."""
MARGIN_PERIODS = 30.0
"""Cutoff periods of samples filtered on either side of a block (see the module notes)."""


def spans(n: int, size: int) -> Iterator[tuple[int, int]]:
    """(first, stop) of consecutive blocks of at most `size` of n samples."""
    for first in range(0, n, size):
        yield first, min(n, first + size)


def compute_metrics_blockwise(
    read: Read,
    n: int,
    given: Sequence[str],
    *,
    tolerance_rad: float = DEFAULT_TOLERANCE_RAD,
    min_force_N: float = DEFAULT_MIN_FORCE_N,
    reaches: Sequence[Reach] | None = None,
    speed_cutoff_hz: float | None = DEFAULT_SPEED_CUTOFF_HZ,
    torque_cutoff_hz: float | None = DEFAULT_TORQUE_CUTOFF_HZ,
    filter_order: int = DEFAULT_FILTER_ORDER,
    movement_fraction: float = DEFAULT_ONSET_FRACTION,
    min_peak_speed_m_s: float = DEFAULT_MIN_PEAK_SPEED_M_S,
    initial_window_s: float = DEFAULT_INITIAL_WINDOW_S,
    block: int = BLOCK,
) -> TrialMetrics:
    """`compute_metrics` of the n samples `read` gives, a block of `block` samples at a
    time (the module notes): the same figures to rounding, the intervals of Fig. 3.9 left
    out. `given` names the roles besides "t_s" and "position_m" that there are."""
    tolerance_rad, min_force_N = checked_options(tolerance_rad, min_force_N, movement_fraction)
    given = set(given)
    trial = _Trial(read, n, block)
    dt_s = trial.sample_interval()
    # the speed, for the passes over it after this one (closed when they are done)
    speed_file = tempfile.TemporaryFile()  # noqa: SIM115
    try:
        return _figures(read, n, given, trial, dt_s, speed_file, tolerance_rad, min_force_N,
                        reaches, speed_cutoff_hz, torque_cutoff_hz, filter_order,
                        movement_fraction, min_peak_speed_m_s, initial_window_s, block)
    finally:
        speed_file.close()


def _figures(read, n, given, trial, dt_s, speed_file, tolerance_rad, min_force_N, reaches,
             speed_cutoff_hz, torque_cutoff_hz, filter_order, movement_fraction,
             min_peak_speed_m_s, initial_window_s, block) -> TrialMetrics:
    """The passes over the blocks of `compute_metrics_blockwise`."""
    nan = math.nan
    pair = (nan, nan)
    has = given.__contains__
    squares = np.zeros(2)
    desired_length = 0.0
    force_low, force_high = np.full(2, math.inf), np.full(2, -math.inf)
    isb_low, isb_high, isb_sum = np.full(2, math.inf), np.full(2, -math.inf), np.zeros(2)
    torque_low, torque_high = np.full(2, math.inf), np.full(2, -math.inf)
    smooth_low, smooth_high = np.full(2, math.inf), np.full(2, -math.inf)
    work = np.zeros(4)
    helped = 0
    path_length, peak = 0.0, -math.inf
    cone = _TimeWithin()
    position = _Smoothed(trial, "position_m", dt_s, speed_cutoff_hz, filter_order)
    torque = _Smoothed(trial, "torque_Nm", dt_s, torque_cutoff_hz, filter_order)
    last: dict[str, np.ndarray] = {}  # each role's sample before the block

    def with_last(role: str, values: np.ndarray) -> np.ndarray:
        before = last.get(role)
        last[role] = values[-1:]
        return values if before is None else np.concatenate((before, values))

    for a, b in spans(n, block):
        t = read("t_s", a, b)
        p = read("position_m", a, b)
        if has("desired_position_m"):
            d = read("desired_position_m", a, b)
            error = p - d
            squares += np.sum(error * error, axis=0)
            desired_length += float(np.sum(np.hypot(*np.diff(with_last("d", d), axis=0).T)))
        if has("force_N"):
            f = read("force_N", a, b)
            force_low, force_high = _low_high(f, force_low, force_high)
            if has("desired_direction"):
                within = force_within(f, read("desired_direction", a, b), tolerance_rad,
                                      min_force_N)
                cone.add(t, within[:n - 1 - a] if b == n else within)
            if has("robot_torque_Nm") and has("robot_angle_rad"):
                own = (with_last("own", read("robot_own_torque_Nm", a, b))
                       if has("robot_own_torque_Nm") else None)
                work += work_terms(with_last("tau", read("robot_torque_Nm", a, b)),
                                   with_last("q", read("robot_angle_rad", a, b)),
                                   with_last("f", f), with_last("p", p), own)
        if has("isb_angles_rad"):
            isb = read("isb_angles_rad", a, b)
            isb_low, isb_high = _low_high(isb, isb_low, isb_high)
            isb_sum += np.sum(isb, axis=0)
        if has("torque_Nm"):
            tau = read("torque_Nm", a, b)
            torque_low, torque_high = _low_high(tau, torque_low, torque_high)
            if torque_cutoff_hz is not None:
                smooth_low, smooth_high = _low_high(torque.values(a, b), smooth_low,
                                                    smooth_high)
        if has("help_torque_Nm"):
            helped += int(np.sum(helped_samples(read("help_torque_Nm", a, b))))
        speed = np.hypot(*position.rate(a, b).T)
        speed.tofile(speed_file)
        path_length += float(np.trapezoid(with_last("s", speed), with_last("t", t)))
        peak = max(peak, float(speed.max()))

    t_first, t_last = trial.t_first, trial.t_last
    rmse = (tuple(float(v) for v in np.sqrt(squares / n)) if has("desired_position_m")
            else pair)
    if not has("desired_position_m"):
        desired_length = nan
    force_range = tuple(float(v) for v in force_high - force_low) if has("force_N") else pair
    direction_pct = (100.0 * cone.time_within(t_last) / float(t_last - t_first)
                     if has("force_N") and has("desired_direction") else nan)
    rom, correlation = pair, nan
    if has("isb_angles_rad"):
        rom = tuple(float(v) for v in isb_high - isb_low)
        correlation = _pearson(trial, isb_sum / n)
    torque_range = (tuple(float(v) for v in torque_high - torque_low) if has("torque_Nm")
                    else pair)
    smoothed_range = (tuple(float(v) for v in smooth_high - smooth_low)
                      if has("torque_Nm") and torque_cutoff_hz is not None else pair)
    speeds = _Stored(speed_file, n, block)

    onset = offset = mean_speed = trial_sparc = trial_ldlj = nan
    if peak >= min_peak_speed_m_s:
        onset, offset, first, last_index = _movement_interval(trial, speeds,
                                                              movement_fraction * peak)
        if last_index > first:
            mean_speed = (_trapezoid(trial, speeds, first, last_index + 1)
                          / (trial.t_at(last_index) - trial.t_at(first)))
        trial_sparc = sparc_of_blocks(speeds.blocks, n, dt_s)
        if last_index - first >= 3:
            trial_ldlj = _ldlj(position, first, last_index + 1, dt_s, block)

    work_figures = MechanicalWork(nan, nan, nan, nan)
    if has("force_N") and has("robot_torque_Nm") and has("robot_angle_rad"):
        work_figures = work_shares(*(float(v) for v in work))
    led = 100.0 * (1.0 - helped / n) if has("help_torque_Nm") else nan
    per_reach = _reaches(trial, position, reaches, movement_fraction, min_peak_speed_m_s,
                         initial_window_s) if reaches else ()
    return assemble(float(t_last - t_first), rmse, direction_pct, tolerance_rad, min_force_N,
                    force_range, rom, torque_range, smoothed_range, path_length,
                    desired_length, peak, onset, offset, mean_speed, trial_sparc, trial_ldlj,
                    correlation, (), (), per_reach, work_figures, led)


class _Trial:
    """The samples' reader, their count and block size, and the time stamps' figures."""

    def __init__(self, read: Read, n: int, block: int) -> None:
        if n < 2:
            raise ParameterError("t_s", f"{n} samples", "at least 2 samples")
        self.read, self.n, self.block = read, n, block
        self.t_first = self.t_last = math.nan

    def t_at(self, i: int) -> float:
        return float(self.read("t_s", i, i + 1)[0])

    def sample_interval(self) -> float:
        """core.signal.sample_interval over the blocks: the median step from the counts of
        each step's value (a clock's ticks have a handful), the same checks."""
        counts: dict[float, int] = {}
        before = None
        worst, worst_at = -math.inf, -1
        for a, b in spans(self.n, self.block):
            t = self.read("t_s", a, b)
            if not np.isfinite(t).all():
                index = a + int(np.flatnonzero(~np.isfinite(t))[0])
                raise ParameterError("t_s", f"not finite at sample {index}", "finite times in s")
            stamps = t if before is None else np.concatenate((before, t))
            offset = a if before is None else a - 1  # the step from sample offset + i
            step = np.diff(stamps)
            if (step <= 0.0).any():
                index = offset + int(np.flatnonzero(step <= 0.0)[0]) + 1
                raise ParameterError("t_s", f"not increasing at sample {index}",
                                     "strictly increasing times in s")
            if len(step):
                i = int(np.argmax(step))
                if step[i] > worst:
                    worst, worst_at = float(step[i]), offset + i
                for value, count in zip(*np.unique(step, return_counts=True), strict=True):
                    counts[float(value)] = counts.get(float(value), 0) + int(count)
            if before is None:
                self.t_first = float(t[0])
            before = t[-1:]
        self.t_last = float(before[0])
        dt_s = _median(counts)
        if worst > MAX_GAP_RATIO * dt_s:
            raise ParameterError(
                "t_s", f"a gap of {worst:g} s after sample {worst_at}",
                f"steps of at most {MAX_GAP_RATIO:g} × the median step {dt_s:g} s",
                "filters and spectra assume even sampling; analyse the parts separately",
            )
        return dt_s


def _median(counts: dict[float, int]) -> float:
    """np.median of the values counted: the middle one, or the mean of the middle two."""
    values = sorted(counts)
    total = sum(counts.values())
    wanted = [(total - 1) // 2, total // 2]
    found, seen = [], 0
    for value in values:
        seen += counts[value]
        while len(found) < 2 and wanted[len(found)] < seen:
            found.append(value)
    return float(np.mean(found))


class _Smoothed:
    """A role's zero-lag low-passed samples and rate on any stretch (the module notes)."""

    def __init__(self, trial: _Trial, role: str, dt_s: float, cutoff_hz: float | None,
                 order: int) -> None:
        self.trial, self.role, self.dt_s = trial, role, dt_s
        self.cutoff_hz, self.order = cutoff_hz, order
        self.margin = 0 if cutoff_hz is None else math.ceil(MARGIN_PERIODS
                                                            / (cutoff_hz * dt_s))

    def _stretch(self, a: int, b: int, extra: int) -> tuple[np.ndarray, int]:
        lo = max(0, a - self.margin - extra)
        hi = min(self.trial.n, b + self.margin + extra)
        raw = self.trial.read(self.role, lo, hi)
        if self.cutoff_hz is None:
            return raw, lo
        return lowpass(raw, self.dt_s, self.cutoff_hz, self.order, name=self.role), lo

    def values(self, a: int, b: int) -> np.ndarray:
        smooth, lo = self._stretch(a, b, 0)
        return smooth[a - lo:b - lo]

    def rate(self, a: int, b: int) -> np.ndarray:
        """np.gradient's rate (core.signal.smoothed_derivatives) on samples a…b−1."""
        smooth, lo = self._stretch(a, b, 1)
        if len(smooth) < 4:
            raise ParameterError(self.role, f"{len(smooth)} samples", "at least 4 samples")
        return np.gradient(smooth, self.dt_s, axis=0, edge_order=2)[a - lo:b - lo]


class _Stored:
    """A series written block by block to a file, read back a block at a time."""

    def __init__(self, file, n: int, block: int) -> None:
        self.file, self.n, self.block = file, n, block

    def read(self, a: int, b: int) -> np.ndarray:
        self.file.seek(a * 8)
        return np.fromfile(self.file, dtype=float, count=b - a)

    def blocks(self) -> Iterator[np.ndarray]:
        for a, b in spans(self.n, self.block):
            yield self.read(a, b)


class _TimeWithin:
    """`directional_performance`'s time within the cone, its runs followed across blocks:
    each run's duration added in the same order, so the same sum bit for bit."""

    def __init__(self) -> None:
        self.state: bool | None = None
        self.since = math.nan
        self.total = 0.0

    def add(self, t: np.ndarray, held: np.ndarray) -> None:
        if not len(held):
            return
        if self.state is None:
            self.state, self.since = bool(held[0]), float(t[0])
        changes = np.flatnonzero(held[1:] != held[:-1]) + 1
        if bool(held[0]) != self.state:
            changes = np.concatenate(([0], changes))
        for j in changes.tolist():
            if self.state:
                self.total += float(t[j]) - self.since
            self.state, self.since = bool(held[j]), float(t[j])

    def time_within(self, t_last: float) -> float:
        return self.total + (t_last - self.since if self.state else 0.0)


def _low_high(values: np.ndarray, low: np.ndarray, high: np.ndarray):
    return np.minimum(low, values.min(axis=0)), np.maximum(high, values.max(axis=0))


def _pearson(trial: _Trial, mean: np.ndarray) -> float:
    """core.metrics.pearson of the ISB shoulder and elbow angles, about their means."""
    xx = yy = xy = 0.0
    for a, b in spans(trial.n, trial.block):
        centred = trial.read("isb_angles_rad", a, b) - mean
        x, y = centred[:, 0], centred[:, 1]
        xx += float(x @ x)
        yy += float(y @ y)
        xy += float(x @ y)
    denominator = math.sqrt(xx * yy)
    if denominator == 0.0:
        return math.nan
    return float(np.clip(xy / denominator, -1.0, 1.0))


def _movement_interval(trial: _Trial, speeds: _Stored, threshold: float):
    """core.metrics.movement_interval from the stored speed."""
    first = last = -1
    for a, b in spans(trial.n, trial.block):
        above = np.flatnonzero(speeds.read(a, b) >= threshold)
        if len(above):
            first = a + int(above[0]) if first < 0 else first
            last = a + int(above[-1])

    def crossing(i: int) -> float:
        return _cross(trial.read("t_s", i, i + 2), speeds.read(i, i + 2), 0, 1, threshold)

    onset = trial.t_first if first == 0 else crossing(first - 1)
    offset = trial.t_last if last == trial.n - 1 else crossing(last)
    return onset, offset, first, last


def _trapezoid(trial: _Trial, speeds: _Stored, first: int, stop: int) -> float:
    """np.trapezoid of the speed over samples first…stop−1, block by block."""
    total = 0.0
    for a, b in spans(stop - first, trial.block):
        lo, hi = first + a, min(stop, first + b + 1)  # one sample shared with the next
        if hi - lo > 1:
            total += float(np.trapezoid(speeds.read(lo, hi), trial.read("t_s", lo, hi)))
    return total


def _ldlj(position: _Smoothed, first: int, stop: int, dt_s: float, block: int) -> float:
    """core.smoothness.ldlj of the smoothed velocity over samples first…stop−1: its peak
    speed and the trapezoid of its squared jerk (second_difference), block by block."""
    peak, integral = 0.0, 0.0
    h2 = dt_s * dt_s
    before = tail = last_squared = None
    for a, b in spans(stop - first, block):
        v = position.rate(first + a, first + b)
        peak = max(peak, float(np.linalg.norm(v, axis=1).max()))
        stretch = v if before is None else np.concatenate((before, v))
        tail = stretch[-4:] if tail is None else np.concatenate((tail, v))[-4:]
        jerk = (stretch[2:] - 2.0 * stretch[1:-1] + stretch[:-2]) / h2  # interior samples
        if before is None:  # the first sample's one-sided stencil
            jerk = np.concatenate((second_difference(stretch[:4], dt_s)[:1], jerk))
        if b == stop - first:  # the last sample's
            jerk = np.concatenate((jerk, second_difference(tail, dt_s)[-1:]))
        squared = np.sum(jerk * jerk, axis=1)
        if last_squared is not None:
            squared = np.concatenate((last_squared, squared))
        integral += float(np.trapezoid(squared, dx=dt_s))
        last_squared = squared[-1:]
        before = stretch[-2:]
    return ldlj_value((stop - first - 1) * dt_s, peak, integral)


def _reaches(trial: _Trial, position: _Smoothed, reaches: Sequence[Reach], fraction: float,
             min_peak: float, window_s: float):
    """core.reaches.reach_metrics of each reach on its own samples (from its target's
    onset to the next one's), with the sample before them, so that its bounds are the
    whole trial's."""
    onsets = [reach.onset_s for reach in reaches]
    bounds = np.zeros(len(onsets), dtype=int)
    for a, b in spans(trial.n, trial.block):
        bounds += np.searchsorted(trial.read("t_s", a, b), onsets, side="left")
    stops = [*bounds[1:].tolist(), trial.n]
    out = []
    for reach, start, stop in zip(reaches, bounds.tolist(), stops, strict=True):
        # at least two samples, so that a reach without any gets reach_metrics' NaN
        lo = max(0, start - 1)
        hi = min(trial.n, max(stop, lo + 2))
        out.extend(reach_metrics(trial.read("t_s", lo, hi), trial.read("position_m", lo, hi),
                                 position.rate(lo, hi), [reach], onset_fraction=fraction,
                                 min_peak_speed_m_s=min_peak, initial_window_s=window_s))
    return tuple(out)


def percentiles_of_blocks(blocks: Callable[[], Iterator[np.ndarray]], n: int,
                          percents: Sequence[float]) -> list[float]:
    """np.percentile (its default, linear) of `n` finite float values that `blocks()` gives
    a block at a time, each time it is called, without holding them: each order
    statistic the percentiles need is found by a radix selection on the values' bit
    patterns (an order-preserving key), 16 bits a pass over the blocks."""
    if n < 1:
        raise ParameterError("values", "none", "at least one finite value")
    wanted = []
    for percent in percents:
        index = (n - 1) * (float(percent) / 100.0)  # numpy's virtual index, "linear"
        if index >= n - 1:
            wanted.append((n - 1, n - 1, 0.0))
        else:
            below = math.floor(index)
            wanted.append((below, below + 1, index - below))
    ranks = sorted({r for below, above, _ in wanted for r in (below, above)})
    found = _order_statistics(blocks, ranks)
    out = []
    for below, above, t in wanted:
        a, b = found[below], found[above]
        diff = b - a  # numpy's _lerp
        out.append(float(a + diff * t) if t < 0.5 else float(b - diff * (1.0 - t)))
    return out


def _order_statistics(blocks, ranks: list[int]) -> dict[int, float]:
    """The values of the given 0-based ranks among the blocks' values."""
    first = next(iter(blocks()))
    kind = np.dtype(first.dtype if first.dtype.kind == "f" else float)
    width = kind.itemsize * 8
    unsigned = np.dtype(f"u{kind.itemsize}")
    top = np.array(1, dtype=unsigned) << np.array(width - 1, dtype=unsigned)

    def keys(values):
        bits = np.ascontiguousarray(values, dtype=kind).view(unsigned)
        return np.where(bits & top, ~bits, bits | top)

    # per rank: the key's bits found so far and the rank left within them
    known = {r: (0, r) for r in ranks}
    for level in range(width // 16):
        shift = np.array(width - 16 * (level + 1), dtype=unsigned)
        prefixes = {prefix for prefix, _ in known.values()}
        counts = {prefix: np.zeros(1 << 16, dtype=np.int64) for prefix in prefixes}
        for block in blocks():
            k = keys(block)
            high = k >> (shift + np.array(16, dtype=unsigned)) if level else None
            digit = ((k >> shift) & np.array(0xFFFF, dtype=unsigned)).astype(np.int64)
            for prefix, count in counts.items():
                chosen = digit if level == 0 else digit[high == prefix]
                count += np.bincount(chosen, minlength=1 << 16)
        for r, (prefix, left) in known.items():
            cumulative = np.cumsum(counts[prefix])
            d = int(np.searchsorted(cumulative, left, side="right"))
            known[r] = ((prefix << 16) | d, left - (int(cumulative[d - 1]) if d else 0))
    out = {}
    for r, (key, _) in known.items():
        bits = np.array([key], dtype=unsigned)
        bits = np.where(bits & top, bits ^ top, ~bits)
        out[r] = float(bits.view(kind)[0])
    return out
