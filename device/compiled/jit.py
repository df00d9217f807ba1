"""numba, set up once for the compiled tick: one decorator and an on-disk cache
(device.compiled.cachedir says where, and why it is keyed by the source)."""

from __future__ import annotations

from numba import njit
from numba.core import config

from device.compiled.cachedir import CACHE_DIR

if CACHE_DIR is not None:
    config.CACHE_DIR = str(CACHE_DIR)


def kernel(function):
    """Compile `function` in nopython mode. Floating-point errors give inf/NaN as in
    numpy (error_model="numpy") rather than exceptions: the kernels test their
    results for finiteness and hand anything odd back to the Python path."""
    return njit(cache=CACHE_DIR is not None, nogil=True, error_model="numpy")(function)
