"""The window's device worker publishes the robot's live records and the trial's events on
the Lab Streaming Layer (`rehab gui --lsl-outlet`), each record stamped at its sensor read
on the loop's clock of its own connection; a failing outlet never stops the live view.

The end-to-end test runs the real loop on the simulator through the worker, as the window
does, with an LSL inlet as LabRecorder would hold one: five Connect/Disconnect cycles of
ten trials each (fifty starts). Every tick of every trial file is in the stream at its own
stamp with its own values, the stream never goes back in time, and each trial's start
marker carries its settings at the stamp of its first tick. Before, a trial's first ticks
were lost when the worker read them before the start event, and after a reconnect the
previous origin was reused (samples 12.5 s early, the stream going back 9.5 s)."""

import json
import queue
import threading
import time
import uuid

import numpy as np
import pylsl
import pytest
from PySide6.QtCore import QTimer

from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.messages import BackendConfig, ClockStarted, TrialMarker
from device.lsl.outlet import RobotStateOutlet
from device.recording.record import empty_records
from device.recording.trialfile import SubjectInfo
from ui.device_bridge import DeviceBridge

CYCLES, STARTS = 5, 10
PARAMS = THESIS_SUBJECT.replace(repetitions=1)


class FakeClient:
    """The DeviceClient calls the worker makes: start, close, live_batch, events."""

    def __init__(self):
        self.records = queue.Queue()
        self.queued_events = queue.Queue()
        self.seq = 0

    def start(self):
        pass

    def close(self, signal=""):
        return []

    def live_batch(self):
        try:
            records = self.records.get_nowait()
        except queue.Empty:
            records = empty_records(0)
        first, self.seq = self.seq, self.seq + len(records)
        return records, first

    def events(self, timeout=0.0):
        out = []
        while not self.queued_events.empty():
            out.append(self.queued_events.get_nowait())
        return out


def _wait(condition, what, timeout=10.0):
    deadline = time.monotonic() + timeout
    while not condition():
        assert time.monotonic() < deadline, f"{what} did not happen"
        time.sleep(0.01)


def _inlets(source):
    state = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source, 1, 5.0)[0],
                              max_buflen=600)
    markers = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source + "-events", 1,
                                                     5.0)[0])
    state.open_stream(5.0)
    markers.open_stream(5.0)
    return state, markers


def test_records_read_before_their_clock_message_still_reach_the_inlet_on_it():
    source = f"test-{uuid.uuid4().hex[:12]}"
    outlet = RobotStateOutlet(500.0, source_id=source)
    client = FakeClient()
    bridge = DeviceBridge(client=client, lsl_outlet=outlet)
    state, _ = _inlets(source)
    _wait(outlet.have_consumers, "the inlet connecting")
    origin = time.monotonic() - 3.0
    records = empty_records(200)
    records["wall_time"] = 1.0 + 0.002 * np.arange(200)
    records["position"] = np.column_stack((np.arange(200.0), -np.arange(200.0)))
    # the worker meets the records first, their connection's clock in the same drain
    client.records.put(records)
    client.queued_events.put(ClockStarted(origin, 0))
    bridge.start()
    try:
        got, stamps = [], []

        def more():
            x, t = state.pull_chunk(timeout=0.1)
            got.extend(x)
            stamps.extend(t)
            return len(got) >= 200

        _wait(more, "200 records arriving")
        np.testing.assert_allclose(np.array(got)[:, :2], records["position"])
        np.testing.assert_allclose(stamps, origin + records["wall_time"], atol=1e-6)
    finally:
        bridge.close()
    assert bridge.take_records().shape[0] == 200  # the live view got them too


def test_a_failing_outlet_is_dropped_and_the_live_view_goes_on():
    class Broken:
        def clock_started(self, *args):
            pass

        def push_records(self, *args):
            raise RuntimeError("network gone")

        def close(self):
            pass

    client = FakeClient()
    bridge = DeviceBridge(client=client, lsl_outlet=Broken())
    bridge.start()
    try:
        client.queued_events.put(ClockStarted(time.monotonic(), 0))
        client.records.put(empty_records(10))
        _wait(lambda: bridge.lsl_outlet is None, "the outlet being dropped")
        client.records.put(empty_records(5))
        got = []
        _wait(lambda: got.append(len(bridge.take_records())) or sum(got) == 15, "15 records")
    finally:
        bridge.close()


def _command(qtbot, bridge, name, *args):
    with qtbot.waitSignal(bridge.replied, timeout=30000,
                          check_params_cb=lambda command, ok, message: command == name) as got:
        getattr(bridge, name)(*args)
    assert got.args[1], f"{name}: {got.args[2]}"


def _again_while_settling(qtbot, bridge, name, args, settling):
    """Press a button again while the loop says it is still settling, as the therapist
    does: the recorder's "closed" notice can reach the console before the loop has heard
    the file is closed (Start: "the last trial is still being closed; wait a moment") or
    has finished stopping (Disconnect: "not possible while stopping"). Under a loaded
    machine those gaps lasted long enough to refuse the test's command."""
    deadline = time.monotonic() + 30.0
    while True:
        with qtbot.waitSignal(bridge.replied, timeout=30000,
                              check_params_cb=lambda command, ok, message:
                              command == name) as got:
            getattr(bridge, name)(*args)
        ok, message = got.args[1], got.args[2]
        if ok:
            return
        assert settling in message, f"{name}: {message}"
        assert time.monotonic() < deadline, f"{name} still refused after 30 s: {message}"
        qtbot.wait(50)


class _Recording:
    """An inlet drained on its own thread, as LabRecorder does, until its stream is gone
    (recover=False: a lost stream ends the pull instead of waiting for it to come back)."""

    def __init__(self, info):
        self.inlet = pylsl.StreamInlet(info, max_buflen=600, recover=False)
        self.inlet.open_stream(5.0)
        self.values, self.stamps = [], []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self):
        while not self._stop.is_set():
            try:
                x, t = self.inlet.pull_chunk(timeout=0.2, max_samples=10000)
            except pylsl.util.LostError:
                return
            self.values.extend(x)
            self.stamps.extend(t)

    def stop(self):
        self._stop.set()
        self._thread.join(10.0)
        return np.array(self.values), np.array(self.stamps)


@pytest.mark.slow
def test_no_tick_is_lost_at_start_and_no_stamp_goes_back_across_connects(qtbot, tmp_path):
    source = f"test-{uuid.uuid4().hex[:12]}"
    outlet = RobotStateOutlet(500.0, source_id=source)
    state = _Recording(pylsl.resolve_byprop("source_id", source, 1, 5.0)[0])
    markers = _Recording(pylsl.resolve_byprop("source_id", source + "-events", 1, 5.0)[0])
    _wait(outlet.have_consumers, "the inlet connecting")
    bridge = DeviceBridge(lsl_outlet=outlet)
    bridge.start()
    beat = QTimer()
    beat.timeout.connect(bridge.heartbeat)
    beat.start(100)
    subject = SubjectInfo.from_parameters("PTEST01", PARAMS)
    files = []
    try:
        _command(qtbot, bridge, "build", PARAMS, BackendConfig(seed=11))
        for cycle in range(CYCLES):
            _command(qtbot, bridge, "connect")
            for start in range(STARTS):
                path = tmp_path / f"c{cycle}-s{start}.h5"
                with qtbot.waitSignal(bridge.file_notice, timeout=30000,
                                      check_params_cb=lambda kind, p, *_, path=path:
                                      kind == "closed" and p == str(path)):
                    _again_while_settling(qtbot, bridge, "start_trial", (str(path), subject),
                                          "still being closed")
                    qtbot.wait(10 * (start % 4))  # stopped 0 to 30 ms into the approach
                    _command(qtbot, bridge, "stop")
                files.append(path)
            _again_while_settling(qtbot, bridge, "disconnect", (), "while stopping")
            qtbot.wait(50)
    finally:
        beat.stop()
        bridge.close()
        qtbot.wait(1000)  # what is on its way
        values, stamps = state.stop()
        text, marker_stamps = markers.stop()
    assert np.all(np.diff(stamps) > 0), "the robot stream went back in time"
    events = [(json.loads(m[0]), t) for m, t in zip(text, marker_stamps, strict=True)]
    starts = [(e, t) for e, t in events if e["event"] == "start"]
    assert len(starts) == CYCLES * STARTS
    at = {round(t, 9): k for k, t in enumerate(stamps)}
    for path, (start, start_stamp) in zip(files, starts, strict=True):
        data = read_trial(path)
        origin = data.summary["wall_time_origin_monotonic_s"]
        file_stamps = origin + data.channels["wall_time"]
        rows = [at.get(round(t, 9)) for t in file_stamps]
        missing = [k for k, row in enumerate(rows) if row is None]
        assert not missing, f"{path.name}: ticks {missing[:5]}… of {len(rows)} not in the stream"
        np.testing.assert_array_equal(values[rows][:, :2], data.channels["position"])
        assert start["file"] == str(path)
        assert start["parameters"]["shape"] == PARAMS.shape
        assert start_stamp == pytest.approx(file_stamps[0], abs=1e-9)
    assert not any(isinstance(e, TrialMarker) for e in events)  # JSON, not objects
    kinds = {e["event"] for e, _ in events}
    assert {"start", "stop", "phase"} <= kinds
