"""What a headless run's ticks leave of each tick (`run_ticks`' output, device.loop.engine)
and the records made from it.

`run_ticks` writes a row of ROW_* values a tick; `records_from_rows` turns a block of those
rows into the trial's records (device.recording.record.RECORD_DTYPE) in `record_values`'
order, the layout read off `record_values` itself so that it is written once. Apart from
the engine so that each stays a module one reads whole.
"""

from __future__ import annotations

import numpy as np

from core.interaction import SubjectState
from device.backend import SensorReading
from device.loop.control_kernel import C_SIZE
from device.loop.pipeline import TickPipeline, record_values
from device.loop.states import State
from device.recording.record import RECORD_DTYPE

# What `run_ticks` leaves of one tick, in its output's row for the tick (the tick's
# quantities side by side, so that a tick writes one contiguous stretch; in columns, one
# per quantity, a tick's 48 writes fell a block's length apart: about 5 % of the ticks'
# time): the reading, what `control` left, the torques written and the fault code.
ROW_READING = 0
ROW_LAST = ROW_READING + 6
ROW_APPLIED = ROW_LAST + C_SIZE
ROW_FAULT = ROW_APPLIED + 2
ROW_SUBJECT = ROW_FAULT + 1  # the subject's state (core.interaction.SubjectState's order)
ROW_SIZE = ROW_SUBJECT + 13


def records_from_rows(rows: np.ndarray, pipeline: TickPipeline,
                      first_tick: int = 0) -> np.ndarray:
    """`run_ticks`' output (a row of ROW_* by tick, from tick `first_tick`) as records
    (record_values' order): wall time the robot's time, no lateness or compute time.

    The float channels that are `run_ticks`' values side by side in both (_RUNS) are
    copied a run of channels at a time, each record's run in one stretch of bytes:
    channel by channel, each of 53 copies went through the whole block of records. The
    other channels' casts are the ones a channel's assignment made, so the records are
    the same bit for bit."""
    n = rows.shape[0]
    records = np.empty(n, dtype=RECORD_DTYPE)
    raw = records.view(np.uint8).reshape(n, RECORD_DTYPE.itemsize)
    columns = np.ascontiguousarray(rows).view(np.uint8)
    for offset, row, count in _RUNS:
        # a run as one opaque item of its bytes: one copy a record (as float64 the copy
        # went value by value, the records' floats being unaligned)
        run = np.dtype((np.void, 8 * count))
        raw[:, offset:offset + 8 * count].view(run)[...] = (
            columns[:, 8 * row:8 * (row + count)].view(run))
    tick = np.arange(first_tick, first_tick + n)
    time_s = tick * pipeline.period_s
    # contiguous, as the whole-array kernels always had them
    q1 = np.ascontiguousarray(rows[:, ROW_READING + 1])
    q2 = np.ascontiguousarray(rows[:, ROW_READING + 2])
    fault = rows[:, ROW_FAULT]
    computed = {"tick": tick, "time": time_s, "zero": np.zeros(n),
                "state": np.where(fault != 0, int(State.FAULTED), int(State.RUNNING))}
    computed["x"], computed["y"] = pipeline.robot.position(q1, q2)
    for (name, component), source in _SINGLES:
        value = computed[source] if isinstance(source, str) else rows[:, source]
        if component is None:
            records[name] = value
        else:
            records[name][:, component] = value
    return records


def _flat_fields(dtype: np.dtype) -> tuple[tuple[str, int | None], ...]:
    """(field, component) of each value of a record in flat_names order."""
    fields = []
    for name in dtype.names:
        shape = dtype.fields[name][0].shape
        fields.extend([(name, None)] if not shape else [(name, i) for i in range(shape[0])])
    return tuple(fields)


_FLAT_FIELDS = _flat_fields(RECORD_DTYPE)


def _record_sources() -> tuple:
    """Where each record value (flat_names order) comes from in `records_from_rows`: the
    column (ROW_*) of `run_ticks`' output it is, or the name of what is computed from the
    block ("tick", "time", "zero", "x", "y", "state"). Read off record_values itself,
    called on the columns' numbers, so the record's layout is written once."""
    columns = list(range(ROW_SIZE))
    return record_values(
        "tick", "time", "time", "zero", "zero",
        SensorReading(*columns[ROW_READING:ROW_READING + 6]), columns[ROW_LAST:ROW_LAST + C_SIZE],
        columns[ROW_APPLIED:ROW_APPLIED + 2], ("x", "y"),
        SubjectState(*columns[ROW_SUBJECT:ROW_SUBJECT + 13]), "state", ROW_FAULT)


def _record_copies() -> tuple[tuple, tuple]:
    """(_RUNS, _SINGLES): runs of float64 values that are neighbours both in a record and
    in `run_ticks`' row, as (byte offset in the record, first column, count); every other
    value as ((field, component), source)."""
    runs: list[list[int]] = []
    singles = []
    for (name, component), source in zip(_FLAT_FIELDS, _record_sources(), strict=True):
        field, offset = RECORD_DTYPE.fields[name][:2]
        if isinstance(source, str) or field.base != np.float64:
            singles.append(((name, component), source))
            continue
        offset += 8 * (component or 0)
        last = runs[-1] if runs else None
        if last and last[0] + 8 * last[2] == offset and last[1] + last[2] == source:
            last[2] += 1
        else:
            runs.append([offset, source, 1])
    return tuple(map(tuple, runs)), tuple(singles)


_RUNS, _SINGLES = _record_copies()
