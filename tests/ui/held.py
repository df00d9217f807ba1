"""A registry call that answers only once the test lets it: a shared registry on a network
that drops everything answers after its bounded wait (app.records.registry.postgres.
deadline); here never before the test says, so nothing depends on how long the window
takes meanwhile. A window that waits for the call on its own thread never gives the test
its turn: the call then gives up after BOUND_S, and `waited` says so."""

from __future__ import annotations

import threading

BOUND_S = 30.0
"""How long a held call waits for the test at most: a hang's bound."""


class Held:
    """The registry's `name`, answering only once the test calls `release` (for the
    patient `code` only, when given): `asked` is set as the call comes, `waited` says
    for each whether the test released it before the bound (False: the window waited
    for it on its own thread, where the test could not)."""

    def __init__(self, monkeypatch, registry, name: str, code: str | None = None) -> None:
        self.asked = threading.Event()
        self._released = threading.Event()
        self.waited: list[bool] = []
        call = getattr(registry, name)

        def held(*args, **kwargs):
            if code is None or code in args:
                self.asked.set()
                self.waited.append(self._released.wait(BOUND_S))
            return call(*args, **kwargs)

        monkeypatch.setattr(registry, name, held)

    def release(self) -> None:
        self._released.set()
