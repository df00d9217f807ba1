"""h5py's views of a group's members and of attributes, read whole before they are used.

h5py's item and value views (`group.items()`, `group.values()`, `attrs.items()`) hold
h5py's global lock ("phil") across each `yield`. Consumed lazily, an exception raised by
our own code between two items (a damaged attribute that does not read as a plain value)
leaves the view's generator suspended on the exception's traceback, still holding the
lock. Should that exception end its life in a reference cycle (a concurrent.futures
Future and its exception make one), the cyclic garbage collector closes the generator in
whichever thread it happens to run, the lock's release fails there ("cannot release
un-acquired lock", which the collector ignores) and every other thread that touches h5py
waits for ever: a window's job thread finishing a trial deadlocked so in a whole check
(2026-12-04). h5py documents the lock and the collector's part in such deadlocks (its
docs on file-like objects and threads; h5py#2019). `list()` reads the view whole inside
h5py, which lets go of the lock before our code sees the first item.
"""

from __future__ import annotations


def items(mapping) -> list:
    """`mapping.items()` (an h5py group or attributes) as a list read whole."""
    return list(mapping.items())


def values(mapping) -> list:
    """`mapping.values()` (an h5py group) as a list read whole."""
    return list(mapping.values())
