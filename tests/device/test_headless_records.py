"""A headless run's records are made from `run_ticks`' rows a run of channels at a time
(device.loop.tickrows.records_from_rows): they must be the records the channel-by-channel
assignment of record_values made, bit for bit, NaN and the sign of zero included."""

import numpy as np

from core.interaction import SubjectState
from core.trial import THESIS_SUBJECT
from device.backend import SensorReading
from device.loop import tickrows
from device.loop.pipeline import C_ACTIVE, C_SIZE, TickPipeline, TrialPlan, record_values
from device.loop.states import State
from device.loop.tickrows import (
    ROW_APPLIED,
    ROW_FAULT,
    ROW_LAST,
    ROW_READING,
    ROW_SIZE,
    ROW_SUBJECT,
    records_from_rows,
)
from device.recording.record import RECORD_DTYPE


def channel_by_channel(rows: np.ndarray, pipeline: TickPipeline, first: int) -> np.ndarray:
    """The records as they were made before: record_values on whole columns, each value
    assigned to its channel."""
    n = rows.shape[0]
    columns = np.ascontiguousarray(rows.T)
    tick = np.arange(first, first + n)
    time_s = tick * pipeline.period_s
    reading = SensorReading(*columns[ROW_READING:ROW_READING + 6])
    fault = columns[ROW_FAULT]
    state = np.where(fault != 0, int(State.FAULTED), int(State.RUNNING))
    zeros = np.zeros(n)
    values = record_values(tick, time_s, time_s, zeros, zeros, reading,
                           columns[ROW_LAST:ROW_LAST + C_SIZE],
                           columns[ROW_APPLIED:ROW_APPLIED + 2],
                           pipeline.robot.position(reading.q1_rad, reading.q2_rad),
                           SubjectState(*columns[ROW_SUBJECT:ROW_SUBJECT + 13]), state, fault)
    records = np.empty(n, dtype=RECORD_DTYPE)
    for (name, component), value in zip(tickrows._FLAT_FIELDS, values, strict=True):
        if component is None:
            records[name] = value
        else:
            records[name][:, component] = value
    return records


def test_records_are_the_channel_by_channel_records_bit_for_bit():
    pipeline = TickPipeline(TrialPlan.build(THESIS_SUBJECT), compiled=True)
    rng = np.random.default_rng(3)
    rows = rng.normal(size=(1_001, ROW_SIZE))
    rows[rng.random(rows.shape) < 0.05] = np.nan
    rows[rng.random(rows.shape) < 0.02] = -0.0
    rows[:, ROW_READING + 1:ROW_READING + 3] = rng.uniform(1.0, 2.0, (1_001, 2))
    rows[:, ROW_LAST] = rng.integers(0, 4, 1_001)  # the phase
    rows[:, ROW_LAST + C_ACTIVE] = rng.integers(0, 2, 1_001)
    rows[:, ROW_FAULT] = np.where(rng.random(1_001) < 0.1, 7.0, 0.0)
    rows[:, ROW_SUBJECT + 12] = rng.integers(0, 2, 1_001)  # damped
    for first, stretch in ((0, slice(None)), (25_000, slice(3, 700))):
        made = records_from_rows(rows[stretch], pipeline, first)
        assert made.tobytes() == channel_by_channel(rows[stretch], pipeline, first).tobytes()


def test_every_run_copied_whole_is_float64_neighbours_in_both():
    """The runs (byte offset in the record, first column, count) lie inside float64
    channels and cover every value not computed or cast apart."""
    covered = sum(count for _, _, count in tickrows._RUNS)
    assert covered + len(tickrows._SINGLES) == len(tickrows._FLAT_FIELDS)
    for offset, column, count in tickrows._RUNS:
        assert column >= 0
        assert column + count <= ROW_SIZE
        assert offset + 8 * count <= RECORD_DTYPE.itemsize
