"""How long a test waits for something a live process does: until it happens, with a
deadline only a hang reaches.

CI runs on a shared 2-core virtual machine whose host can stall a process, or all of them,
for 20 s and more (a whole check failed twice that way: a window's Connect not seen in
20 s, a loop's first samples not seen in 10 s, both passing alone). A test must not
depend on how promptly the machine wakes a process, so every wait in the suite on a Qt
condition or signal (pytest-qt's qtbot) gets at least HANG_S, and the loop client's
default waits (device.loop.client.PATIENCE_S) a minute, three for Build and Connect: a
wait still returns the moment its event comes, and a hung process still fails the test,
with the wait's own message, only later.
"""

from __future__ import annotations

import functools

HANG_S = 180.0
"""A deadline no stall of a live process has come near (the longest seen: ~25 s)."""
HANG_MS = int(HANG_S * 1000)
LOOP_PATIENCE_S = 60.0
"""The loop client's default wait in the tests (its PATIENCE_S)."""

_QTBOT_WAITS = ("waitUntil", "waitSignal", "waitSignals", "waitCallback", "waitActive",
                "waitExposed")
"""pytest-qt's waits that take a `timeout` in ms (5 s by default); `qtbot.wait(ms)`, a
fixed pause, is not one of them."""


def _patient(wait):
    @functools.wraps(wait)
    def waiting(*args, timeout: int | None = 5000, **kwargs):
        # 0 and None mean "no deadline" to pytest-qt: left as they are
        if timeout:
            timeout = max(timeout, HANG_MS)
        return wait(*args, timeout=timeout, **kwargs)

    waiting.__patient__ = True
    return waiting


def patient_loop_client() -> None:
    """Give the loop client's default waits LOOP_PATIENCE_S (a minute; three for Build
    and Connect): for tests/conftest.py and the test scripts that drive a loop in a
    process of their own (tests/device/live_console.py)."""
    from device.loop import client

    client.PATIENCE_S = max(client.PATIENCE_S, LOOP_PATIENCE_S)


def be_patient() -> None:
    """Give every qtbot wait HANG_S at least, and the loop client its LOOP_PATIENCE_S
    (called by tests/conftest.py before any test runs)."""
    from pytestqt.qtbot import QtBot

    patient_loop_client()
    for name in _QTBOT_WAITS:
        wait = getattr(QtBot, name)
        if not getattr(wait, "__patient__", False):
            setattr(QtBot, name, _patient(wait))
