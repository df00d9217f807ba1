"""A registry write the window asks of its job thread and may stop waiting for.

A Start's trial (ui.window.start) and a plan's run (ui.window.plan) are begun in the
registry on the job thread; on a shared registry whose network drops everything the answer
comes after the bounded wait (app.records.registry.postgres.deadline). The window closing
meanwhile does not wait for it: it abandons the write (`abandon`), and whatever the write
made is undone on the job thread, by the job itself once its answer comes, or by a job the
window gives as it closes when the answer had come but was not yet taken. The two threads
meet under one lock, so exactly one of them undoes it and never neither.
"""

from __future__ import annotations

import threading
from typing import Generic, TypeVar

T = TypeVar("T")


class Awaited(Generic[T]):
    def __init__(self) -> None:
        self._lock = threading.Lock()
        self.made: T | None = None
        """The write's result, set on the job thread as it comes."""
        self.abandoned = ""
        """Why the window stopped waiting ('' while it waits)."""

    def answered(self, made: T) -> str:
        """On the job thread, the write's result: '' when the window still waits for it,
        else why it stopped (the job then undoes `made` itself, there)."""
        with self._lock:
            self.made = made
            return self.abandoned

    def abandon(self, why: str) -> T | None:
        """The window stops waiting (it closes): the result already made, for the window to
        have undone on the job thread; None when none came yet (the job undoes it)."""
        with self._lock:
            self.abandoned = why
            return self.made
