"""A loop shared by a module's tests (a module-scoped DeviceClient) brought to no robot
connected, whatever the test before left."""

from __future__ import annotations

from device.loop.states import State
from tests.patience import HANG_S


def disconnected(client) -> None:
    """No robot connected: the test before ended its trial and its file closed, but the
    loop may still be stopping (on a loaded host: "build refused: not possible while
    stopping" in a whole check, and every test after it refused as well)."""
    if client.state in (State.RUNNING, State.STOPPING):
        client.wait_for(lambda event: client.state not in (State.RUNNING, State.STOPPING),
                        HANG_S)
    if client.state in (State.CONNECTED, State.FAULTED):
        assert client.disconnect().ok
