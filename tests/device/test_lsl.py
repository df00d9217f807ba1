"""The Lab Streaming Layer: the EMG inlet and the robot's outlet, each against a real local
pylsl outlet or inlet (liblsl from pylsl's wheel, confined to loopback by tests/conftest.py).
Streams get unique names and source ids, so runs beside each other on one machine never
see each other's streams."""

import json
import socket
import time
import uuid
from pathlib import Path

import numpy as np
import pylsl
import pytest
from hypothesis import given, strategies as st

from device.loop.messages import TrialMarker
from device.lsl import inlet as inlet_module
from device.lsl.inlet import DUPLICATE_LOOK_S, LslEmgInlet
from device.lsl.library import LOOPBACK_CONFIG, LslError, find_streams
from device.lsl.outlet import (
    EVENT_STREAM,
    ROBOT_CHANNELS,
    ROBOT_STREAM,
    RobotStateOutlet,
    station_source_id,
)
from device.lsl.timeline import MarkerQueue, RingClocks
from device.recording.record import empty_records


@pytest.fixture(autouse=True)
def _brief_duplicate_look(monkeypatch):
    """Every stream these tests make has a name of its own, so the inlet's second look for
    another of the name (DUPLICATE_LOOK_S, 1 s at every inlet made) is 0.1 s here; the
    one test of a duplicate name looks its whole second."""
    monkeypatch.setattr(inlet_module, "DUPLICATE_LOOK_S", 0.1)


def _emg_outlet(name, channels=16, rate=2000.0, fmt=pylsl.cf_float32, unit="volts",
                labels=None, scaling=None):
    info = pylsl.StreamInfo(name, "EMG", channels, rate, fmt, f"{name}-source")
    if unit is not None or labels is not None:
        described = info.desc().append_child("channels")
        for k in range(channels):
            channel = described.append_child("channel")
            channel.append_child_value("label", labels[k] if labels else f"EMG{k + 1}")
            if unit is not None:
                channel.append_child_value("unit", unit if isinstance(unit, str) else unit[k])
            if scaling is not None:
                channel.append_child_value("scaling_factor", scaling)
    return pylsl.StreamOutlet(info)


def _wait_for(condition, what, timeout=10.0):
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            pytest.fail(f"{what} did not happen in {timeout} s")
        time.sleep(0.01)


def _unique():
    return f"test-{uuid.uuid4().hex[:12]}"


def _receive(inlet, n):
    got_t, got_x = [], []
    _wait_for(lambda: (got := inlet.read(0.2)) and (got_t.append(got[0]), got_x.append(got[1]))
              and sum(t.size for t in got_t) >= n, f"{n} samples arriving")
    return np.concatenate(got_t), np.concatenate(got_x)


def test_the_suite_keeps_liblsl_on_this_machine():
    import os

    with open(os.environ["LSLAPICFG"]) as f:
        assert f.read() == LOOPBACK_CONFIG
    assert "ResolveScope = machine" in LOOPBACK_CONFIG
    assert "MachineAddresses = {127.0.0.1}" in LOOPBACK_CONFIG


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
    t, x = _receive(inlet, 3000)
    np.testing.assert_array_equal(x, sent.astype(float))
    # on one machine the clock correction is tiny: the stamps are the sender's
    np.testing.assert_allclose(t, stamps, atol=5e-3)
    assert inlet.rate_hz == 2000.0
    assert inlet.channel_count == 16
    assert inlet.labels == tuple(f"EMG{k}" for k in range(1, 17))
    # the LSL clock is the monotonic clock of the loop's wall_time: read between two of its
    # readings (a bound of 50 ms on their difference failed if this thread stalled longer
    # between the two reads, as a loaded 2-core machine does)
    before = time.monotonic()
    lsl_now = pylsl.local_clock()
    assert before <= lsl_now <= time.monotonic()
    inlet.close()


def test_the_inlet_keeps_the_stamps_as_sent_so_the_file_says_what_was_moved_and_lost():
    """The inlet asks liblsl for its clock offset only (proc_clocksync), not to dejitter or
    monotonize (device.lsl.inlet says why). Measured here (brief hT): with proc_monotonize
    a stamp that went back came equal to the one before, which the trial file refuses as
    well, and nothing told how many; with proc_dejitter every stamp was replaced by a
    regression line and 100 lost samples (a 50 ms step) were smeared into 1.4 ms steps,
    counted as 125. The capture repairs the one stamp that went back and says by how
    much, and the hole keeps its size."""
    from device.emg.capture import EmgCapture

    name = _unique()
    outlet = _emg_outlet(name, channels=2, rate=2000.0)
    inlet = LslEmgInlet(name, channels=2, rate_hz=2000.0, timeout_s=5.0).open(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    now = pylsl.local_clock()
    index = np.concatenate((np.arange(200), np.arange(300, 500)))  # 100 lost
    stamps = now + index / 2000.0
    stamps[100:200] -= 0.002  # the second chunk back-dated 2 ms: it goes back
    for k in range(0, 400, 100):
        outlet.push_chunk(np.zeros((100, 2), np.float32), timestamp=stamps[k:k + 100].tolist())
    # started once all is sent (the inlet buffers it): a host's stall between the start
    # and the first push is no source that stopped (STALL_S)
    capture = EmgCapture(inlet).start()
    _wait_for(lambda: capture.snapshot().stamps_s.size >= 400, "400 samples arriving")
    captured = capture.stop()
    assert (np.diff(captured.stamps_s) > 0).all()
    assert captured.missing == 100
    (said,) = [n for n in captured.notes if "stamps" in n]
    depth_ms = float(said.split("by up to ")[1].split(" ms")[0])
    assert depth_ms >= 1.0, said  # the stamp went back 1.5 ms: said as it was
    np.testing.assert_allclose(captured.stamps_s[200:], stamps[200:], atol=5e-3)


def test_the_inlet_keeps_every_clock_offset_it_added_to_the_stamps():
    """liblsl's clock offset was added to the stamps (proc_clocksync) and known to nobody:
    the record could not say what was done to the sender's stamps. The inlet adds it
    itself and keeps each offset with the first stamp it was added to, so every stamp is
    the sender's plus the offset kept for it, to the last bit of a double."""
    name = _unique()
    outlet = _emg_outlet(name, channels=2, rate=2000.0)
    inlet = LslEmgInlet(name, channels=2, rate_hz=2000.0, timeout_s=5.0).open(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    sent = pylsl.local_clock() + np.arange(2000) / 2000.0
    for k in range(0, 2000, 100):
        outlet.push_chunk(np.zeros((100, 2), np.float32), timestamp=sent[k:k + 100].tolist())
    t, _ = _receive(inlet, 2000)
    starts = np.array([start for start, _ in inlet.clock_offsets])
    offsets = np.array([offset for _, offset in inlet.clock_offsets])
    assert starts[0] == t[0]  # the first offset from the first sample on
    assert (np.diff(starts) > 0).all()
    assert np.all(np.abs(offsets) < 5e-3)  # one machine: a clock offset of almost nothing
    added = offsets[np.searchsorted(starts, t, side="right") - 1]
    # the sender's stamps back to within rounding: (s + offset) - offset is s to an ulp of
    # a monotonic clock's seconds (2e-12 s), which exact equality failed in a whole run
    np.testing.assert_allclose(t - added, sent, rtol=0, atol=1e-9)
    assert inlet.clock_offset_s == offsets[-1]
    inlet.close()


@pytest.mark.parametrize(("fmt", "dtype", "unit", "volts"), [
    (pylsl.cf_int16, np.int16, "microvolts", 1e-6),
    (pylsl.cf_int32, np.int32, "uV", 1e-6),
    (pylsl.cf_int16, np.int16, "\u00b5V", 1e-6),
    (pylsl.cf_int8, np.int8, "mV", 1e-3),
    (pylsl.cf_int64, np.int64, "nV", 1e-9),
    (pylsl.cf_float32, np.float32, "millivolts", 1e-3),
    (pylsl.cf_double64, np.float64, "V", 1.0),
], ids=["int16-microvolts", "int32-uV", "int16-µV", "int8-mV", "int64-nV", "float32-mV",
        "double-V"])
def test_every_numeric_format_is_read_in_volts_by_its_declared_unit(fmt, dtype, unit, volts):
    """An int16 or int32 stream was read into a float buffer (values like ±1e294, NaN) and a
    unit was ignored (microvolts stored as volts, a 10⁶ error)."""
    name = _unique()
    outlet = _emg_outlet(name, channels=3, rate=1000.0, fmt=fmt, unit=unit)
    inlet = LslEmgInlet(name, timeout_s=5.0).open(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    top = min(np.iinfo(dtype).max, 30000) if np.issubdtype(dtype, np.integer) else 3e4
    sent = np.linspace(-top, top, 3 * 500).reshape(500, 3).astype(dtype)
    outlet.push_chunk(sent)
    _, x = _receive(inlet, 500)
    np.testing.assert_array_equal(x, sent.astype(float) * volts)
    assert inlet.units == (unit,) * 3
    inlet.close()


@pytest.mark.parametrize(("fmt", "dtype", "scaling", "volts"), [
    (pylsl.cf_int16, np.int16, "0.1", 1e-7),
    (pylsl.cf_int32, np.int32, "0.5", 5e-7),
    (pylsl.cf_int16, np.int16, "10.000000", 1e-5),
    (pylsl.cf_float32, np.float32, "1", 1e-6),
], ids=["int16-0.1", "int32-0.5", "int16-10", "float32-1"])
def test_a_raw_integer_stream_is_scaled_by_its_declared_scaling_factor(fmt, dtype, scaling,
                                                                        volts):
    """A BrainAmp's raw int16 stream says `microvolts` and a scaling_factor of 0.1 (its
    resolution); the factor was ignored and its counts read as whole microvolts, ten times
    too large."""
    name = _unique()
    outlet = _emg_outlet(name, channels=2, rate=1000.0, fmt=fmt, unit="microvolts",
                         scaling=scaling)
    inlet = LslEmgInlet(name, timeout_s=5.0).open(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    outlet.push_chunk(np.array([[1000, -250]] * 10, dtype=dtype))
    _, x = _receive(inlet, 10)
    np.testing.assert_allclose(x[0], np.array([1000, -250]) * volts, rtol=1e-12)
    inlet.close()


@pytest.mark.parametrize("scaling", ["0", "-0.1", "fine", "nan"])
def test_a_scaling_factor_that_is_no_positive_number_is_refused_in_one_line(scaling):
    name = _unique()
    outlet = _emg_outlet(name, channels=1, rate=1000.0, fmt=pylsl.cf_int16, unit="uV",
                         scaling=scaling)
    with pytest.raises(LslError, match=rf"gives EMG1 a scaling_factor of '{scaling}', not a "
                                       "positive number") as refused:
        LslEmgInlet(name, timeout_s=5.0)
    assert "\n" not in str(refused.value)
    del outlet


def test_a_channel_without_a_voltage_unit_is_refused_in_one_line_unless_given():
    bare = _unique()
    outlet = _emg_outlet(bare, channels=2, rate=1000.0, fmt=pylsl.cf_int16, unit=None)
    with pytest.raises(LslError, match=r"does not say the unit of channel 1: declare each "
                                       r"channel's unit .* or give it \(lsl:NAME@uV\)"):
        LslEmgInlet(bare, timeout_s=5.0)
    inlet = LslEmgInlet(bare, timeout_s=5.0, unit="uV").open(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    outlet.push_chunk(np.array([[1000, -2000]] * 10, dtype=np.int16))
    _, x = _receive(inlet, 10)
    np.testing.assert_array_equal(x[0], [1e-3, -2e-3])
    inlet.close()
    with pytest.raises(LslError, match=r"unit 'kg' given .* is not a voltage"):
        LslEmgInlet(bare, timeout_s=5.0, unit="kg")
    odd = _unique()
    other = _emg_outlet(odd, channels=2, rate=1000.0, unit=("uV", "counts"),
                        labels=("biceps", "triceps"))
    with pytest.raises(LslError, match=r"gives triceps in 'counts', not a voltage") as refused:
        LslEmgInlet(odd, timeout_s=5.0)
    assert "\n" not in str(refused.value)
    declared = _unique()
    third = _emg_outlet(declared, channels=1, rate=1000.0, unit="mV")
    with pytest.raises(LslError, match=r"declares EMG1 in 'mV', not in 'uV' as given"):
        LslEmgInlet(declared, timeout_s=5.0, unit="uV")
    del outlet, other, third


def _brainamp_outlet(name, labels, resolution="100 nV"):
    """Brain Products' BrainAmpSeries app's float stream with `Sampled Markers in EEG`, its
    description as the app writes it (brain-products/App-BrainAmpSeries, mainwindow.cpp
    read_thread): type EEG, each channel type EEG in microvolts, scaling_factor 1, then
    the trigger channel `triggerStream` of type EEG and unit `code`."""
    info = pylsl.StreamInfo(name, "EEG", len(labels) + 1, 1000.0, pylsl.cf_float32,
                            f"{name}_SR-1000.000000")
    channels = info.desc().append_child("channels")
    for label in labels:
        channels.append_child("channel").append_child_value("label", label) \
            .append_child_value("type", "EEG").append_child_value("unit", "microvolts") \
            .append_child_value("scaling_factor", "1")
    channels.append_child("channel").append_child_value("label", "triggerStream") \
        .append_child_value("type", "EEG").append_child_value("unit", "code")
    info.desc().append_child("amplifier").append_child("settings") \
        .append_child_value("resolution", resolution).append_child_value("dc_coupling", "AC")
    info.desc().append_child("acquisition").append_child_value("manufacturer",
                                                               "Brain Products")
    return pylsl.StreamOutlet(info)


def _liveamp_outlet(name, channels):
    """Brain Products' LiveAmp app's stream (brain-products/LSL-LiveAmp, mainwindow.cpp
    ReadThread): type EEG, float32, channels (label, type, unit) as it appends them: EEG,
    bipolar and AUX in microvolts, ACC_X/Y/Z (type ACC, milliGs; its shipped configuration
    has `useACC=true`), `SampleCounter` (type SampleCounter, unit ''), `DeviceTrigger` and
    `STETriggerIn` (type Trigger, unit integer), `STESync` (type SyncPulse, unit integer);
    older versions appended `Markers` (type Markers, unit '')."""
    info = pylsl.StreamInfo(name, "EEG", len(channels), 500.0, pylsl.cf_float32, name)
    described = info.desc().append_child("channels")
    for label, kind, unit in channels:
        described.append_child("channel").append_child_value("label", label) \
            .append_child_value("type", kind).append_child_value("unit", unit)
    info.desc().append_child("acquisition").append_child_value("manufacturer",
                                                               "Brain Products")
    return pylsl.StreamOutlet(info)


LIVEAMP_EMG = [("Fz", "EEG", "microvolts"), ("biceps", "bipolar", "microvolts"),
               ("triceps", "AUX", "microvolts")]
LIVEAMP_EXTRA = [("ACC_X", "ACC", "milliGs"), ("ACC_Y", "ACC", "milliGs"),
                 ("ACC_Z", "ACC", "milliGs"), ("SampleCounter", "SampleCounter", ""),
                 ("DeviceTrigger", "Trigger", "integer"),
                 ("STETriggerIn", "Trigger", "integer"), ("STESync", "SyncPulse", "integer")]


def test_a_brainamp_stream_is_read_without_its_trigger_channel_said_in_one_line():
    """The whole stream was refused for BrainAmpSeries' trigger channel (unit `code`)."""
    name = f"BrainAmpSeries-Dev_1-{_unique()}"
    outlet = _brainamp_outlet(name, ("biceps", "triceps"))
    inlet = LslEmgInlet(name, timeout_s=5.0).open(5.0)
    assert (inlet.labels, inlet.channel_count) == (("biceps", "triceps"), 2)
    assert len(inlet.notes) == 1
    assert "\n" not in inlet.notes[0]
    assert "triggerStream" in inlet.notes[0]
    assert "unit 'code'" in inlet.notes[0]
    _wait_for(outlet.have_consumers, "the inlet connecting")
    sent = np.array([[120.5, -40.25, -1.0]] * 10 + [[3.0, 4.0, 7.0]], dtype=np.float32)
    outlet.push_chunk(sent)
    _, x = _receive(inlet, 11)
    np.testing.assert_allclose(x, sent[:, :2].astype(float) * 1e-6, rtol=1e-12)
    inlet.close()


def test_a_liveamp_stream_as_its_app_ships_keeps_its_emg_and_leaves_the_rest_in_one_line():
    """The LiveAmp app's shipped configuration streams its accelerometer (`useACC=true`):
    the whole stream was refused for ACC_X in milliGs, and for its sample counter."""
    name = f"LiveAmpSN-{_unique()}"
    outlet = _liveamp_outlet(name, LIVEAMP_EMG + LIVEAMP_EXTRA)
    inlet = LslEmgInlet(name, timeout_s=5.0).open(5.0)
    assert inlet.labels == ("Fz", "biceps", "triceps")
    assert len(inlet.notes) == 1
    (note,) = inlet.notes
    assert "\n" not in note
    for label, _, _ in LIVEAMP_EXTRA:
        assert label in note
    assert "an accelerometer (type 'ACC')" in note
    assert "a sample counter" in note
    assert "a sync pulse" in note
    _wait_for(outlet.have_consumers, "the inlet connecting")
    row = [1.0, 2.0, 3.0, 980.0, -12.0, 4.0, 17.0, -1.0, -1.0, 1.0]
    outlet.push_chunk(np.array([row] * 4, dtype=np.float32))
    _, x = _receive(inlet, 4)
    np.testing.assert_allclose(x[0], [1e-6, 2e-6, 3e-6], rtol=1e-6)
    inlet.close()
    del outlet


def test_older_liveamp_markers_are_left_out_and_an_undeclared_channel_still_refuses():
    name = f"LiveAmpSN-{_unique()}"
    outlet = _liveamp_outlet(name, [*LIVEAMP_EMG, ("Markers", "Markers", "")])
    inlet = LslEmgInlet(name, timeout_s=5.0).open(5.0)
    assert inlet.labels == ("Fz", "biceps", "triceps")
    assert "Markers, a trigger/marker channel" in inlet.notes[0]
    inlet.close()
    # a channel in milliGs that does not say it is an accelerometer may be a mislabelled
    # electrode: said, never dropped
    unsaid = f"LiveAmpSN-{_unique()}"
    other = _liveamp_outlet(unsaid, [*LIVEAMP_EMG, ("ACC_X", "MISC", "milliGs")])
    with pytest.raises(LslError, match=r"gives ACC_X in 'milliGs', not a voltage") as refused:
        LslEmgInlet(unsaid, timeout_s=5.0)
    assert "\n" not in str(refused.value)
    typed = f"LiveAmpSN-{_unique()}"
    third = _liveamp_outlet(typed, [*LIVEAMP_EMG, ("Resp", "RESP", "microvolts")])
    with pytest.raises(LslError, match=r"gives Resp as type 'RESP', not EMG"):
        LslEmgInlet(typed, timeout_s=5.0)
    only = f"LiveAmpSN-{_unique()}"
    fourth = _liveamp_outlet(only, LIVEAMP_EXTRA)
    with pytest.raises(LslError, match=r"has no EMG channel, only ACC_X, an accelerometer"):
        LslEmgInlet(only, timeout_s=5.0)
    del outlet, other, third, fourth


def test_streams_are_listed():
    name = _unique()
    outlet = _emg_outlet(name, channels=4, rate=1000.0)
    _wait_for(lambda: any(s.name == name for s in find_streams(0.5)), "the stream being seen")
    seen = next(s for s in find_streams(1.0) if s.name == name)
    assert (seen.type, seen.channel_count, seen.nominal_rate_hz) == ("EMG", 4, 1000.0)
    del outlet


def test_a_missing_or_wrong_stream_is_one_clear_line(monkeypatch):
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
    monkeypatch.setattr(inlet_module, "DUPLICATE_LOOK_S", DUPLICATE_LOOK_S)  # the real look
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
        records[name] = rng.standard_normal(shape) if name != "phase" else 0
    records["phase"][n // 3:] = 2
    records["wall_time"] = origin_wall_s + np.arange(n) * 0.002
    return records


def test_the_robot_outlet_describes_its_channels_for_labrecorder_and_the_xdf_readers():
    source = _unique()
    outlet = RobotStateOutlet(500.0, source_id=source)
    found = pylsl.resolve_byprop("source_id", source, 1, 5.0)
    assert [i.name() for i in found] == [ROBOT_STREAM]
    assert (found[0].type(), found[0].channel_count(), found[0].nominal_srate()) == (
        "MoCap", 9, 500.0)
    full = pylsl.StreamInlet(found[0]).info(5.0)
    channel = full.desc().child("channels").child("channel")
    described = []
    for _ in range(9):
        described.append(tuple(channel.child_value(k) for k in ("label", "unit", "type")))
        channel = channel.next_sibling()
    assert described == [(label, unit, kind) for _, _, label, unit, kind in ROBOT_CHANNELS]
    assert described[0] == ("position_x", "meters", "PositionX")
    assert full.desc().child("acquisition").child_value("manufacturer")
    events = pylsl.resolve_byprop("source_id", source + "-events", 1, 5.0)
    assert [i.name() for i in events] == [EVENT_STREAM]
    # one station, one source id, whenever the console starts
    assert station_source_id() == station_source_id() == f"rehab-console@{socket.gethostname()}"
    outlet.close()


def test_the_robot_outlet_stamps_each_record_at_its_sensor_read_with_markers():
    source = _unique()
    outlet = RobotStateOutlet(500.0, source_id=source)
    inlet = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source, 1, 5.0)[0])
    events = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source + "-events", 1,
                                                    5.0)[0])
    inlet.open_stream(5.0)
    events.open_stream(5.0)
    _wait_for(outlet.have_consumers, "the inlet connecting")
    origin = time.monotonic() - 10.0
    records = _records(1000)
    outlet.clock_started(7000, origin)
    # the trial's start is announced before its record (seq 7400) is pushed
    outlet.mark(TrialMarker("start", "trial started", {"parameters": {"shape": "circle"}}, 0,
                            7400, time.monotonic()))
    for k in range(0, 1000, 50):
        outlet.push_records(records[k:k + 50], 7000 + k)
    got_x, got_t = [], []

    def more():
        x, t = inlet.pull_chunk(timeout=0.2, max_samples=1000)
        got_x.extend(x)
        got_t.extend(t)
        return len(got_t) >= 1000

    _wait_for(more, "1000 robot samples")
    np.testing.assert_allclose(np.array(got_x), RobotStateOutlet.rows(records))
    np.testing.assert_allclose(got_t, origin + records["wall_time"], atol=1e-6)
    seen = []
    _wait_for(lambda: seen.append(events.pull_sample(timeout=0.5)) or len(
        [s for s in seen if s[0]]) >= 3, "three markers")
    markers = [(json.loads(m[0]), t) for m, t in seen if m]
    kinds = [m["event"] for m, _ in markers]
    assert kinds == ["phase", "phase", "start"]
    assert markers[1][0]["phase"] == 2
    assert markers[1][1] == pytest.approx(origin + records["wall_time"][1000 // 3], abs=1e-6)
    start, stamp = markers[2]
    assert start["parameters"] == {"shape": "circle"}
    assert stamp == pytest.approx(origin + records["wall_time"][400], abs=1e-6)
    assert outlet.pushed == 1000
    assert outlet.dropped == 0
    outlet.close()


@st.composite
def _connections(draw):
    """Connections one after another: (ticks, origin), and how a reader splits the records
    it reads into batches."""
    count = draw(st.integers(1, 6))
    ticks = draw(st.lists(st.integers(1, 400), min_size=count, max_size=count))
    gaps = draw(st.lists(st.floats(0.05, 30.0), min_size=count, max_size=count))
    cuts = draw(st.lists(st.integers(1, 300), min_size=1, max_size=40))
    return ticks, gaps, cuts


@given(_connections())
def test_every_record_read_before_its_clock_message_is_stamped_on_its_own_clock(drawn):
    """The reader reads a batch of the ring, then the messages; a connection's
    ClockStarted is sent before its first record. Whatever the batches, every record is
    stamped origin + wall_time of its own connection and the stamps only go forward."""
    ticks, gaps, cuts = drawn
    wall, seq_origin, messages = [], [], []
    seq, now = 0, 1000.0
    for n, gap in zip(ticks, gaps, strict=True):
        now += gap
        messages.append((seq, now))  # ClockStarted(origin=now, first_seq=seq)
        wall.extend(0.002 * (1 + np.arange(n)))
        seq_origin.extend([now] * n)
        now += 0.002 * n
        seq += n
    wall, seq_origin = np.array(wall), np.array(seq_origin)
    clocks = RingClocks()
    out, start, k = [], 0, 0
    while start < len(wall):
        end = min(len(wall), start + cuts[k % len(cuts)])
        k += 1
        for first, origin in messages:  # the messages sent before those records were read
            if first < end:
                clocks.started(first, origin)
        out.append(clocks.stamps(wall[start:end], start))
        start = end
    stamps = np.concatenate(out)
    np.testing.assert_array_equal(stamps, seq_origin + wall)
    assert np.all(np.diff(stamps) > 0)
    assert clocks.unstamped == 0


def test_a_marker_waits_for_its_record_and_goes_out_at_its_send_time_when_it_never_comes():
    clocks = RingClocks(history=100)
    queue = MarkerQueue()
    clocks.started(0, 50.0)
    early = TrialMarker("start", "", {}, 0, 10, 99.0)
    queue.add(early)
    assert queue.ready(clocks) == []
    clocks.stamps(0.002 * np.arange(20), 0)
    assert queue.ready(clocks) == [(early, pytest.approx(50.02))]
    lost = TrialMarker("stop", "", {}, 5, 500, 123.0)
    queue.add(lost)
    assert queue.ready(clocks) == []
    assert queue.ready(clocks, flush=True) == [(lost, 123.0)]
    # too old to be remembered: its send time
    clocks.stamps(0.002 * np.arange(300), 20)
    old = TrialMarker("fault", "", {}, 1, 3, 77.0)
    queue.add(old)
    assert queue.ready(clocks) == [(old, 77.0)]


def test_liblsl_is_quiet_unless_someone_configured_it(monkeypatch, tmp_path):
    """`rehab emg streams` printed liblsl's 'api_config.cpp:126 INFO| Loaded default
    config' under its answer: with no configuration of the lab's (LSLAPICFG, lsl_api.cfg),
    liblsl gets its defaults without the log; a lab's or the tests' own is left alone."""
    import sys
    import types

    from device.lsl import library

    monkeypatch.setattr(library, "_log_file", [])
    given = []
    fake = types.SimpleNamespace(set_config_content=given.append)
    monkeypatch.setitem(sys.modules, "pylsl", fake)
    lab = tmp_path / "lsl_api.cfg"
    monkeypatch.setattr(library, "user_config_files", lambda: (lab,))
    monkeypatch.delenv("LSLAPICFG", raising=False)
    assert library.pylsl() is fake
    assert given == [library.QUIET_CONFIG]
    lab.write_text("[log]\nlevel = 0\n")
    library.pylsl()
    assert given == [library.QUIET_CONFIG]  # the lab's file is liblsl's to read
    lab.unlink()
    monkeypatch.setenv("LSLAPICFG", str(tmp_path / "tests.cfg"))
    library.pylsl()
    assert given == [library.QUIET_CONFIG]


_GONE_SENDER = """
import sys, time
from pathlib import Path
import numpy as np
from device.lsl import library
# liblsl as nobody configured it, but kept on this machine: the loopback settings stand in
# for its network defaults
library.QUIET_CONFIG = library.LOOPBACK_CONFIG
library.user_config_files = lambda: ()
library.log_liblsl_into(Path(sys.argv[1]))
pylsl = library.pylsl()
from device.lsl.inlet import LslEmgInlet
name = sys.argv[2]
info = pylsl.StreamInfo(name, "EMG", 1, 1000.0, pylsl.cf_int16, name)
info.desc().append_child("channels").append_child("channel").append_child_value("unit", "uV")
outlet = pylsl.StreamOutlet(info)
inlet = LslEmgInlet(name, timeout_s=10.0).open(10.0)
while not outlet.have_consumers():
    time.sleep(0.01)
del outlet  # the EMG software goes away while its stream is read
deadline = time.monotonic() + float(sys.argv[3])
while "broke off" not in (Path(sys.argv[1]).read_text() if Path(sys.argv[1]).exists() else ""):
    assert time.monotonic() < deadline, "liblsl wrote nothing"
    time.sleep(0.05)
"""


def test_liblsl_writes_a_sender_going_away_into_the_log_file_not_on_stderr(tmp_path):
    """liblsl wrote 'Stream transmission broke off (Input stream error.); re-connecting...'
    on stderr when an EMG sender went away, under the console's own line for it; with the
    console's log folder given it goes there, errors and all."""
    import os
    import subprocess
    import sys

    from tests.patience import HANG_S

    log = tmp_path / "liblsl.log"
    env = {k: v for k, v in os.environ.items() if k != "LSLAPICFG"}
    done = subprocess.run([sys.executable, "-c", _GONE_SENDER, str(log), _unique(),
                           str(HANG_S)], env=env, capture_output=True, text=True,
                          timeout=2 * HANG_S, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "Stream transmission broke off" in log.read_text()
    assert "broke off" not in done.stderr
    assert "ERR" not in done.stderr


def test_a_log_file_liblsl_cannot_read_leaves_its_errors_on_stderr(monkeypatch):
    from device.lsl import library

    monkeypatch.setattr(library, "_log_file", [])
    library.log_liblsl_into(None)
    assert library.quiet_config() == library.QUIET_CONFIG
    library.log_liblsl_into(Path("/data/logs/liblsl.log"))
    assert library.quiet_config().endswith("[log]\nlevel = -2\nfile = /data/logs/liblsl.log\n")
    for odd in ("/data/lo\ngs/liblsl.log", "/data/logs/liblsl.log "):
        library.log_liblsl_into(Path(odd))
        assert library.quiet_config() == library.QUIET_CONFIG


_FIRST_USE = """
import sys
from pathlib import Path
from device.lsl import library
library.QUIET_CONFIG = library.LOOPBACK_CONFIG  # liblsl as nobody configured it, on this machine
library.user_config_files = lambda: ()
library.log_liblsl_into(Path(sys.argv[1]))
library.find_streams(0.1)
print("done")
"""


def test_liblsl_announces_its_log_file_nowhere_on_stderr(tmp_path):
    """`rehab emg streams` printed "loguru.cpp:842 INFO| Logging to '…/logs/liblsl.log'"
    under its answer: liblsl adds its log file before it turns stderr off (its
    api_config.cpp), and loguru announces the file on stderr."""
    import os
    import subprocess
    import sys

    from tests.patience import HANG_S

    log = tmp_path / "liblsl.log"
    env = {k: v for k, v in os.environ.items() if k != "LSLAPICFG"}
    done = subprocess.run([sys.executable, "-c", _FIRST_USE, str(log)], env=env,
                          capture_output=True, text=True, timeout=2 * HANG_S, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert done.stdout == "done\n"
    assert done.stderr == ""
    assert log.exists()  # liblsl's errors still have their file
