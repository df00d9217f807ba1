"""The window's device worker publishes the robot's live records and events on the Lab
Streaming Layer when asked (`rehab gui --lsl-outlet`), stamped on the loop's clock; a
failing outlet never stops the live view."""

import queue
import time
import uuid

import numpy as np
import pylsl
import pytest

from device.emg.lsl import RobotStateOutlet
from device.loop.messages import TrialEnded, TrialStarted
from device.recording.record import empty_records
from ui.device_bridge import DeviceBridge


class FakeClient:
    """The DeviceClient calls the worker makes: start, close, live_records, events."""

    def __init__(self):
        self.records = queue.Queue()
        self.queued_events = queue.Queue()

    def start(self):
        pass

    def close(self, signal=""):
        return []

    def live_records(self):
        try:
            return self.records.get_nowait()
        except queue.Empty:
            return empty_records(0)

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


def test_live_records_and_events_reach_an_lsl_inlet_on_the_loops_clock():
    source = f"test-{uuid.uuid4().hex[:12]}"
    outlet = RobotStateOutlet(500.0, source_id=source)
    client = FakeClient()
    bridge = DeviceBridge(client=client, lsl_outlet=outlet)
    state = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source, 1, 5.0)[0])
    markers = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source + "-events", 1,
                                                     5.0)[0])
    state.open_stream(5.0)
    markers.open_stream(5.0)
    _wait(outlet.have_consumers, "the inlet connecting")
    bridge.start()
    try:
        origin = time.monotonic() - 3.0
        client.queued_events.put(TrialStarted("trial.h5", 100, 1000, origin))
        records = empty_records(200)
        records["wall_time"] = 1.0 + 0.002 * np.arange(200)
        records["position"] = np.column_stack((np.arange(200.0), -np.arange(200.0)))
        time.sleep(0.1)
        client.records.put(records)
        got, stamps = [], []

        def more():
            x, t = state.pull_chunk(timeout=0.1)
            got.extend(x)
            stamps.extend(t)
            return len(got) >= 200

        _wait(more, "200 records arriving")
        np.testing.assert_allclose(np.array(got)[:, :2], records["position"])
        np.testing.assert_allclose(stamps, origin + records["wall_time"], atol=1e-6)
        client.queued_events.put(TrialEnded("trial.h5", "complete", {}))
        seen = []
        _wait(lambda: seen.extend([markers.pull_sample(0.1)[0]]) or
              ["stop: complete"] in seen, "the stop marker")
        assert ["start"] in seen
    finally:
        bridge.close()
    assert bridge.take_records().shape[0] == 200  # the live view got them too


def test_a_failing_outlet_is_dropped_and_the_live_view_goes_on():
    class Broken:
        def push_records(self, *args):
            raise RuntimeError("network gone")

        def push_event(self, *args):
            pass

    client = FakeClient()
    bridge = DeviceBridge(client=client, lsl_outlet=Broken())
    bridge.start()
    try:
        client.queued_events.put(TrialStarted("t.h5", 1, 2, time.monotonic()))
        time.sleep(0.1)
        client.records.put(empty_records(10))
        _wait(lambda: bridge.lsl_outlet is None, "the outlet being dropped")
        client.records.put(empty_records(5))
        got = []
        _wait(lambda: got.append(len(bridge.take_records())) or sum(got) == 15, "15 records")
    finally:
        bridge.close()


def test_trial_started_carries_the_loops_clock_origin_by_default_nan():
    assert np.isnan(TrialStarted("p", 1, 2).wall_time_origin_monotonic_s)
    assert TrialStarted("p", 1, 2, 5.0).wall_time_origin_monotonic_s == pytest.approx(5.0)
