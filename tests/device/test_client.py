"""The console's side of the device link, on fake pipes: no event is ever dropped."""

import time

import pytest

from device.errors import DeviceError
from device.loop.client import LOOP_START_S, DeviceClient
from device.loop.messages import Reply, StateChanged, TrialEnded
from device.loop.states import State


class FakePipe:
    """A Connection whose peer has already sent `incoming`, all in one batch."""

    def __init__(self, incoming=()):
        self.incoming = list(incoming)
        self.sent = []

    def send(self, message):
        self.sent.append(message)

    def poll(self, timeout=0.0):
        return bool(self.incoming)

    def recv(self):
        return self.incoming.pop(0)


def test_events_arriving_with_a_reply_stay_queued():
    """A trial that faults in the tick that starts it: the loop's reply to Start comes in
    one batch with the fault's state change and the trial's end, which must still reach
    the window."""
    client = DeviceClient()
    ended = TrialEnded("/tmp/t.h5", "faulted", {})
    client._conn = FakePipe([StateChanged(int(State.RUNNING), "trial started"),
                             Reply(1, True), StateChanged(int(State.FAULTED), "late"), ended])
    client._notices = FakePipe()
    reply = client.request(type("Start", (), {"id": 1})())
    assert reply == Reply(1, True)
    events = client.events()
    assert [type(e) for e in events] == [StateChanged, StateChanged, TrialEnded]
    assert client.state == State.FAULTED


class StartingPipe(FakePipe):
    """A loop process still starting: its first `silent` polls find nothing, each after
    waiting its whole timeout, as a real pipe's poll does."""

    def __init__(self, incoming=(), silent=0):
        super().__init__(incoming)
        self.silent = silent

    def poll(self, timeout=0.0):
        if self.silent:
            self.silent -= 1
            time.sleep(timeout)
            return False
        return super().poll(timeout)


def test_the_first_command_waits_for_the_loop_process_to_start():
    """The loop process answers nothing until it has imported its modules (numpy, the
    compiled kernels): on a busy 2-core machine the first command's reply came after its
    10 s timeout ("the loop did not answer Start within 10 s", tests/device/test_loop.py's
    first test in a full run at load 9). Until the loop is first heard, a command waits
    LOOP_START_S; after, its own timeout."""
    client = DeviceClient()
    client._conn = StartingPipe([Reply(1, True)], silent=3)
    client._notices = FakePipe()
    assert client.request(type("Build", (), {"id": 1})(), timeout=0.001) == Reply(1, True)
    client._conn = StartingPipe(silent=10**6)  # heard once: a silent loop now times out
    with pytest.raises(DeviceError, match=r"did not answer Stop within 0\.001 s"):
        client.request(type("Stop", (), {"id": 2})(), timeout=0.001)
    assert LOOP_START_S >= 60


class LaterPipe(FakePipe):
    """The loop's pipe, whose `incoming` is written only once the recorder's notice has
    been read: the loop told the console of the fault a moment after the console's first
    look at its pipe, and the recorder's notice on the trial's file came after."""

    def __init__(self, incoming, after):
        super().__init__()
        self.later, self.after = list(incoming), after

    def poll(self, timeout=0.0):
        if self.after.read and self.later:
            self.incoming += self.later
            self.later = []
        return super().poll(timeout)


class NoticePipe(FakePipe):
    read = False

    def recv(self):
        self.read = True
        return super().recv()


def test_a_fault_sent_before_the_recorders_notice_reaches_the_window_first():
    """A trial whose file could not be made: the recorder's "lost" notice is sent after
    the loop's fault (device.loop.process sends the fault before the trial's end reaches
    the recorder), but read in the same look at both pipes it overtook the fault, and the
    registry kept the trial's end without its cause (CI: "The trial file could not be
    written" missing from the trial's end reason)."""
    from device.loop.messages import FaultRaised
    from device.recording.messages import RecorderNotice

    client = DeviceClient()
    fault = FaultRaised(14, "The trial file could not be written", {}, 1.0, 2.0)
    lost = RecorderNotice("lost", "/tmp/t.h5", "recording_lost", "folder gone")
    client._notices = NoticePipe([lost])
    client._conn = LaterPipe([fault], client._notices)
    assert client.events() == [fault, lost]
