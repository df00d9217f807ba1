"""The Lab Streaming Layer: the EMG inlet and the robot's outlet, each against a real local
pylsl outlet or inlet (liblsl from pylsl's wheel). Streams get unique names and source ids,
so runs beside each other on one machine never see each other's streams."""

import time
import uuid

import numpy as np
import pylsl
import pytest

from device.emg.lsl import (
    EVENT_STREAM,
    ROBOT_CHANNELS,
    ROBOT_STREAM,
    LslEmgInlet,
    LslError,
    RobotStateOutlet,
    find_streams,
)
from device.recording.record import empty_records


def _emg_outlet(name, channels=16, rate=2000.0, fmt=pylsl.cf_float32):
    info = pylsl.StreamInfo(name, "EMG", channels, rate, fmt, f"{name}-source")
    return pylsl.StreamOutlet(info)


def _wait_for(condition, what, timeout=10.0):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"{what} did not happen in {timeout} s")
        time.sleep(0.01)


def _unique():
    return f"test-{uuid.uuid4().hex[:12]}"


def test_the_emg_inlet_receives_every_sample_on_the_local_clock():
    name = _unique()
    outlet = _emg_outlet(name)
    inlet = LslEmgInlet(name, channels=16, rate_hz=2000.0, timeout_s=5.0).open(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    rng = np.random.default_rng(0)
    sent = (1e-4 * rng.standard_normal((3000, 16))).astype(np.float32)
    now = pylsl.local_clock()
    stamps = now + np.arange(3000) / 2000.0
    for k in range(0, 3000, 100):
        outlet.push_chunk(sent[k:k + 100], timestamp=stamps[k:k + 100].tolist())
    got_t, got_x = [], []
    _wait_for(lambda: (got := inlet.read(0.2)) and (got_t.append(got[0]), got_x.append(got[1]))
              and sum(t.size for t in got_t) >= 3000, "3000 samples arriving")
    t, x = np.concatenate(got_t), np.concatenate(got_x)
    np.testing.assert_array_equal(x, sent.astype(float))
    # on one machine the clock correction is tiny: the stamps are the sender's
    np.testing.assert_allclose(t, stamps, atol=5e-3)
    assert inlet.rate_hz == 2000.0
    assert inlet.channel_count == 16
    # the LSL clock is the monotonic clock of the loop's wall_time
    assert abs(pylsl.local_clock() - time.monotonic()) < 0.05
    inlet.close()


def test_streams_are_listed():
    name = _unique()
    outlet = _emg_outlet(name, channels=4, rate=1000.0)
    _wait_for(lambda: any(s.name == name for s in find_streams(0.5)), "the stream being seen")
    seen = next(s for s in find_streams(1.0) if s.name == name)
    assert (seen.type, seen.channel_count, seen.nominal_rate_hz) == ("EMG", 4, 1000.0)
    del outlet


def test_a_missing_or_wrong_stream_is_one_clear_line():
    with pytest.raises(LslError, match=r"no LSL stream named 'nothing-.*' found in 0\.5 s"):
        LslEmgInlet(f"nothing-{_unique()}", timeout_s=0.5)
    name = _unique()
    outlet = _emg_outlet(name, channels=8, rate=1000.0)
    with pytest.raises(LslError, match="has 8 channels, 16 expected"):
        LslEmgInlet(name, channels=16, timeout_s=5.0)
    with pytest.raises(LslError, match="runs at 1000 Hz, 2000 Hz expected"):
        LslEmgInlet(name, rate_hz=2000.0, timeout_s=5.0)
    text = _unique()
    markers = _emg_outlet(text, channels=1, rate=0.0, fmt=pylsl.cf_string)
    with pytest.raises(LslError, match="carries text"):
        LslEmgInlet(text, timeout_s=5.0)
    irregular = _unique()
    slow = _emg_outlet(irregular, channels=1, rate=pylsl.IRREGULAR_RATE)
    with pytest.raises(LslError, match="no regular rate"):
        LslEmgInlet(irregular, timeout_s=5.0)
    twice = _unique()
    first, second = _emg_outlet(twice), _emg_outlet(twice)
    _wait_for(lambda: len(pylsl.resolve_byprop("name", twice, 2, 1.0)) == 2, "both seen")
    with pytest.raises(LslError, match=r"2 LSL streams named .* found"):
        LslEmgInlet(twice, timeout_s=5.0)
    del outlet, markers, slow, first, second


def _records(n, origin_wall_s=0.0):
    records = empty_records(n)
    rng = np.random.default_rng(1)
    for name, *_ in ROBOT_CHANNELS:
        shape = records[name].shape
        records[name] = rng.integers(0, 3, shape) if name == "phase" else \
            rng.standard_normal(shape)
    records["wall_time"] = origin_wall_s + np.arange(n) * 0.002
    return records


def test_the_robot_outlet_publishes_state_and_events_for_labrecorder():
    source = _unique()
    outlet = RobotStateOutlet(500.0, source_id=source)
    found = pylsl.resolve_byprop("source_id", source, 1, 5.0)
    assert [i.name() for i in found] == [ROBOT_STREAM]
    info = found[0]
    assert (info.type(), info.channel_count(), info.nominal_srate()) == ("MoCap", 9, 500.0)
    inlet = pylsl.StreamInlet(info)
    full = inlet.info(5.0)
    labels = full.get_channel_labels()
    assert labels == [label for _, _, label, _ in ROBOT_CHANNELS]
    assert full.get_channel_units()[4] == "N*m"
    events = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source + "-events", 1, 5.0)[0])
    assert events.info(5.0).name() == EVENT_STREAM
    inlet.open_stream(5.0)
    events.open_stream(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    origin = time.monotonic() - 10.0
    records = _records(1000)
    for k in range(0, 1000, 50):
        outlet.push_records(records[k:k + 50], origin)
    outlet.push_event("start", "trial started", origin + 0.5)
    got_x, got_t = [], []

    def more():
        x, t = inlet.pull_chunk(timeout=0.2, max_samples=1000)
        got_x.extend(x)
        got_t.extend(t)
        return len(got_t) >= 1000

    _wait_for(more, "1000 robot samples")
    np.testing.assert_allclose(np.array(got_x), RobotStateOutlet.rows(records))
    np.testing.assert_allclose(got_t, origin + records["wall_time"], atol=1e-6)
    marker, stamp = events.pull_sample(timeout=5.0)
    assert marker == ["start: trial started"]
    assert stamp == pytest.approx(origin + 0.5, abs=1e-6)
    assert outlet.pushed == 1000
