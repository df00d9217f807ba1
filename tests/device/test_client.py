"""The console's side of the device link, on fake pipes: no event is ever dropped."""

from device.loop.client import DeviceClient
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
