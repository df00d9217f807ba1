"""One trial's arrays as the tabs read them: filled live from record batches, or from a file.

Live, the window's worker hands over batches of records (numpy structured arrays of
`device.recording.record.RECORD_DTYPE`); `TrialView.append` copies the channels the tabs
draw into column buffers that grow by doubling, so a 30–60 Hz repaint never
reallocates, and the tabs take views (`column`, `exercise`) without copying.
Memory is bounded: once `max_samples` are held, every other sample is dropped
and only every `stride`-th new one kept, so a long trial still shows whole, at
half the resolution each time the bound is met.

The figures a tab shows as big numbers (RMSE, directional performance, ranges)
are kept as running sums over every exercise sample that arrived, before any
thinning, so they equal `app.trials.analysis.analyse` on the same records. They use
`core.metrics` on each batch: the same formulas, never copied here.

Not thread-safe: append in the GUI thread (a batch costs tens of microseconds).
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from app.errors import AppError
from app.pose.store import read_pose
from app.trials.analysis import OWN_CHANNELS, robots_own_torque
from app.trials.reader import TrialData
from core.metrics import DEFAULT_TOLERANCE_RAD, rmse_xy
from core.trial import TrialParameters
from core.work import mechanical_work, work_shares
from device.loop.pipeline import PERIOD_S, PHASE_EXERCISE
from device.recording.record import RECORD_DTYPE
from ui.views.pose import PoseView

# The channels the tabs draw; the rest stay in the trial file.
VIEW_CHANNELS = (
    "time", "phase", "position", "position_desired", "direction_desired", "force",
    "force_angle", "assistance_active", "subject_angle_isb", "subject_torque", "state", "fault",
)
WORK_CHANNELS = ("torque_applied", *OWN_CHANNELS)
"""The channels the work needs beside the view's (core.work.mechanical_work, the help's
with the robot's own torque, app.trials.analysis.robots_own_torque): summed as they
arrive, not kept."""
# Channels whose range over the exercise is kept as it arrives (force, ROM, torque ranges).
RANGED_CHANNELS = ("force", "subject_angle_isb", "subject_torque")

DEFAULT_INITIAL_CAPACITY = 4096
# 2**19 samples: 17 min at 500 Hz in about 60 MB before thinning starts.
DEFAULT_MAX_SAMPLES = 2**19


def _layout(name: str) -> tuple[np.dtype, int]:
    field = RECORD_DTYPE.fields[name][0]
    if field.subdtype is None:
        return field, 1
    base, shape = field.subdtype
    return base, int(np.prod(shape))


class TrialView:
    """The arrays of one trial for the tabs. Columns are (width, capacity) arrays, so
    each component (x, y, shoulder, elbow) is contiguous for the plots.

    `cursor` is a time in the trial's `time` channel (s) for replay scrubbing, or
    None to follow the newest sample.
    """

    def __init__(
        self,
        parameters: TrialParameters | None = None,
        *,
        sample_period_s: float = PERIOD_S,
        initial_capacity: int = DEFAULT_INITIAL_CAPACITY,
        max_samples: int = DEFAULT_MAX_SAMPLES,
    ) -> None:
        if initial_capacity < 2 or max_samples < initial_capacity:
            raise ValueError(
                f"capacity {initial_capacity} and bound {max_samples}: give 2 ≤ initial ≤ bound"
            )
        self.parameters = parameters
        self.sample_period_s = float(sample_period_s)
        self.max_samples = int(max_samples)
        self.tolerance_rad = (
            parameters.tolerance_rad if parameters is not None else DEFAULT_TOLERANCE_RAD
        )
        self.metrics: dict[str, float] | None = None  # the analysis, once the trial is over
        self.finished = False
        self.source: Path | None = None  # the file a replayed trial came from
        # (session, trial) as the registry numbers a replayed registered trial: its file's
        # name keeps the numbers it was recorded under, which a station's sync may have
        # changed since (app.records.station.renumber)
        self.numbers: tuple[int, int] | None = None
        self.pose: PoseView | None = None  # the camera's angles, when `rehab pose` ran
        self.video = None  # a replayed trial's video (app.pose.replay.ReplayVideo), if any
        self.title = ""
        self._cursor: float | None = None
        self._n = 0
        self._capacity = int(initial_capacity)
        self.reallocations = 0
        self.stride = 1
        self._received = 0  # records offered to append, before thinning
        self._columns = {
            name: np.zeros((_layout(name)[1], self._capacity), dtype=_layout(name)[0])
            for name in VIEW_CHANNELS
        }
        self._within = np.zeros(self._capacity, dtype=bool)
        self._ex_start = -1
        self._ex_stop = -1
        # Running figures over every exercise sample received.
        self._ex_count = 0
        self._sq_error = np.zeros(2)
        self._within_time = 0.0
        self._first_t = math.nan
        self._last_t = math.nan
        self._last_within = False
        # who did the work so far (core.work.mechanical_work over every exercise step)
        self._robot_J = 0.0
        self._patient_J = 0.0
        self._help_J = 0.0  # NaN once a step had no robot's own torque (no parameters)
        self._last_work: np.ndarray | None = None  # the last exercise record, for its step
        self._low = {n: np.full(_layout(n)[1], np.inf) for n in RANGED_CHANNELS}
        self._high = {n: np.full(_layout(n)[1], -np.inf) for n in RANGED_CHANNELS}

    # -- building ---------------------------------------------------------------
    @classmethod
    def from_records(cls, records: np.ndarray, parameters: TrialParameters | None = None,
                     **options) -> TrialView:
        options.setdefault("initial_capacity",
                           min(max(2, _pow2(len(records))),
                               options.get("max_samples", DEFAULT_MAX_SAMPLES)))
        view = cls(parameters, **options)
        view.append(records)
        return view

    @classmethod
    def from_trial(cls, data: TrialData) -> TrialView:
        """A finished view of a trial file (replay); the file's metrics come along."""
        n = data.n_samples
        # the work's channels too, read as they pass (`_add_work`), not kept: without them a
        # replay said "robot 0.00 J, patient 0.00 J" of a trial whose file says 1.41 and 1.37
        names = (*VIEW_CHANNELS, *(c for c in WORK_CHANNELS if c in data.channels))
        records = np.zeros(n, dtype=np.dtype([(c, RECORD_DTYPE.fields[c][0]) for c in names]))
        for name in names:
            if name in data.channels:
                records[name] = data.channels[name]
            elif records[name].dtype.kind == "f":
                records[name] = np.nan
        view = cls(data.parameters, sample_period_s=data.sample_period_s,
                   initial_capacity=min(max(2, _pow2(n)), DEFAULT_MAX_SAMPLES))
        view.append(records)
        view.metrics = dict(data.metrics) or None
        view.finished = data.closed
        view.source = data.path
        try:
            view.pose = PoseView.from_group(read_pose(data.path), data.time)
        except AppError:
            view.pose = None  # a damaged pose group must not stop the replay of the trial
        return view

    def append(self, records: np.ndarray) -> None:
        """Add a batch of records (any dtype holding VIEW_CHANNELS by name).

        The g-th record ever received is kept when g is a multiple of `stride`,
        at buffer index g / stride; thinning keeps that correspondence.
        """
        k = len(records)
        if k == 0:
            return
        self._accumulate(records)
        first = self._received
        self._received += k
        pos = 0
        while pos < k:
            offset = (-(first + pos)) % self.stride
            kept = records[pos + offset::self.stride]
            if not len(kept):
                return
            room = self.max_samples - self._n
            if len(kept) <= room:
                self._store(kept)
                return
            self._store(kept[:room])
            pos += offset + room * self.stride
            self._thin()

    def _store(self, records: np.ndarray) -> None:
        k = len(records)
        need = self._n + k
        if need > self._capacity:
            self._grow(need)
        a, b = self._n, need
        for name, column in self._columns.items():
            values = records[name]
            column[:, a:b] = values.T if values.ndim > 1 else values
        angle = self._columns["force_angle"][0, a:b]
        # NaN (force too weak to have a direction) compares False: outside.
        np.less_equal(angle, self.tolerance_rad, out=self._within[a:b])
        exercise = np.flatnonzero(records["phase"] == PHASE_EXERCISE)
        if exercise.size:
            if self._ex_start < 0:
                self._ex_start = a + int(exercise[0])
            self._ex_stop = a + int(exercise[-1]) + 1
        self._n = need

    def _grow(self, need: int) -> None:
        capacity = self._capacity
        while capacity < need:
            capacity *= 2
        capacity = min(capacity, self.max_samples)
        for name, column in self._columns.items():
            grown = np.zeros((column.shape[0], capacity), dtype=column.dtype)
            grown[:, :self._n] = column[:, :self._n]
            self._columns[name] = grown
        within = np.zeros(capacity, dtype=bool)
        within[:self._n] = self._within[:self._n]
        self._within = within
        self._capacity = capacity
        self.reallocations += 1

    def _thin(self) -> None:
        """Keep every other sample in place; from now on keep every 2·stride-th."""
        half = (self._n + 1) // 2
        for column in self._columns.values():
            column[:, :half] = column[:, :self._n:2]
        self._within[:half] = self._within[:self._n:2]
        self._n = half
        self.stride *= 2
        exercise = np.flatnonzero(self._columns["phase"][0, :half] == PHASE_EXERCISE)
        self._ex_start = int(exercise[0]) if exercise.size else -1
        self._ex_stop = int(exercise[-1]) + 1 if exercise.size else -1

    def _accumulate(self, records: np.ndarray) -> None:
        exercise = records["phase"] == PHASE_EXERCISE
        if not exercise.any():
            return
        batch = records[exercise]
        t = batch["time"].astype(float)
        within = batch["force_angle"] <= self.tolerance_rad
        rx, ry = rmse_xy(batch["position"], batch["position_desired"])
        self._sq_error += len(batch) * np.array([rx * rx, ry * ry])
        # Sample k holds over [t_k, t_k+1), as in core.metrics.directional_performance:
        # the previous batch's last sample holds until this batch's first.
        if self._ex_count:
            times = np.concatenate(([self._last_t], t))
            held = np.concatenate(([self._last_within], within[:-1]))
        else:
            times, held = t, within[:-1]
            self._first_t = float(t[0])
        self._within_time += float(np.sum(np.diff(times)[held]))
        self._last_t = float(t[-1])
        self._last_within = bool(within[-1])
        self._ex_count += len(batch)
        self._add_work(batch)
        for name in RANGED_CHANNELS:
            values = batch[name].reshape(len(batch), -1)
            finite = np.isfinite(values)
            if finite.any():
                self._low[name] = np.fmin(self._low[name],
                                          np.where(finite, values, np.inf).min(axis=0))
                self._high[name] = np.fmax(self._high[name],
                                           np.where(finite, values, -np.inf).max(axis=0))

    def _add_work(self, batch: np.ndarray) -> None:
        """The batch's steps of work, with the step from the previous batch's last sample:
        the sums are the trial's, whatever its cut into batches."""
        needed = ("torque_applied", "robot_angle", "force", "position")
        if not all(name in batch.dtype.names for name in needed):
            return
        steps = batch if self._last_work is None else np.concatenate((self._last_work, batch))
        self._last_work = batch[-1:].copy()
        if len(steps) < 2:
            return
        own = None if self.parameters is None else robots_own_torque(
            steps.__getitem__, steps.dtype.names, self.parameters)
        done = mechanical_work(steps["torque_applied"], steps["robot_angle"],
                               steps["force"][:, :2], steps["position"], own)
        if math.isfinite(done.robot_J) and math.isfinite(done.patient_J):
            self._robot_J += done.robot_J
            self._patient_J += done.patient_J
            self._help_J += done.help_J

    # -- sizes ------------------------------------------------------------------
    def __len__(self) -> int:
        return self._n

    @property
    def n(self) -> int:
        return self._n

    @property
    def capacity(self) -> int:
        return self._capacity

    @property
    def received(self) -> int:
        """Records appended so far, including those thinned away."""
        return self._received

    # -- arrays (views, valid until the next append) ------------------------------
    def column(self, name: str) -> np.ndarray:
        """(width, n) view of a channel; width 1 for scalars."""
        return self._columns[name][:, :self._n]

    @property
    def time(self) -> np.ndarray:
        return self._columns["time"][0, :self._n]

    @property
    def within(self) -> np.ndarray:
        """Per sample: the force pointed within the tolerance of the path's direction."""
        return self._within[:self._n]

    @property
    def exercise(self) -> slice:
        """The samples of the exercise phase (empty before it starts)."""
        if self._ex_start < 0:
            return slice(0, 0)
        return slice(self._ex_start, self._ex_stop)

    @property
    def has_exercise(self) -> bool:
        return self._ex_start >= 0

    # -- running figures ----------------------------------------------------------
    @property
    def exercise_samples(self) -> int:
        return self._ex_count

    @property
    def rmse_xy_m(self) -> tuple[float, float]:
        """Position error per axis over the exercise so far (m), as app.trials.analysis."""
        if not self._ex_count:
            return (math.nan, math.nan)
        rx, ry = np.sqrt(self._sq_error / self._ex_count)
        return (float(rx), float(ry))

    @property
    def directional_percent(self) -> float:
        """Share of the exercise time the force was within tolerance (%), as app.trials.analysis."""
        span = self._last_t - self._first_t
        if not self._ex_count or not span > 0:
            return math.nan
        return 100.0 * self._within_time / span

    @property
    def work_J(self) -> tuple[float, float]:
        """(robot, patient) work over the exercise so far (J), as app.trials.analysis."""
        if self._ex_count < 2:
            return (math.nan, math.nan)
        return (self._robot_J, self._patient_J)

    @property
    def help_J(self) -> float:
        """The work of the robot's help over the exercise so far (J), as the trial's metric
        robot_help_work_J; NaN without the parameters or the robot's rates."""
        return self._help_J if self._ex_count >= 2 else math.nan

    @property
    def robot_work_share(self) -> float:
        """The robot's help's share of the positive work so far (0–1), as the trial's
        metric robot_work_share (core.work.MechanicalWork)."""
        robot, patient = self.work_J
        if math.isnan(robot):
            return math.nan
        return work_shares(robot, patient, math.nan, self._help_J).robot_share

    def range_of(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(lowest, highest) per component over the exercise so far; NaN before any."""
        low, high = self._low[name].copy(), self._high[name].copy()
        missing = ~np.isfinite(low)
        low[missing] = np.nan
        high[missing] = np.nan
        return low, high

    # -- replay cursor ------------------------------------------------------------
    @property
    def cursor(self) -> float | None:
        return self._cursor

    @cursor.setter
    def cursor(self, t: float | None) -> None:
        if t is None or self._n == 0:
            self._cursor = None
            return
        time = self.time
        self._cursor = float(min(max(t, time[0]), time[-1]))

    def index_at(self, t: float) -> int:
        """The last sample at or before time t (clamped to the samples held)."""
        if self._n == 0:
            raise IndexError("the view holds no samples yet")
        i = int(np.searchsorted(self.time, t, side="right")) - 1
        return min(max(i, 0), self._n - 1)

    @property
    def current_index(self) -> int:
        """The cursor's sample in replay, the newest one live; -1 when empty."""
        if self._n == 0:
            return -1
        if self._cursor is None:
            return self._n - 1
        return self.index_at(self._cursor)

    @property
    def duration_s(self) -> float:
        return float(self.time[-1] - self.time[0]) if self._n else 0.0


def _pow2(n: int) -> int:
    return 1 << max(1, int(n - 1).bit_length())
