"""numba, set up once: the compiled flavour of the kernels and its on-disk cache.

`compiled(f)` is the kernel `f` (core.kernels) compiled in nopython mode, with every
kernel it calls compiled too and bound in its private globals (core.kernels.Flavour):
the same code the interpreted calls run, so the two give the same numbers.
Floating-point errors give inf/NaN as in numpy (error_model="numpy") rather than
exceptions: the kernels test their results for finiteness where it matters. The cache
(device.compiled.cachedir) is keyed by the kernels' sources.

Compiled without numba's reference-counted memory (`_nrt=False`): a kernel never makes
an array, it only reads and writes the vectors the caller holds, so nothing needs the
counts, and with them every call between kernels with an array and every row taken out
of one counted up and down with atomic instructions: a quarter to a third of a headless
tick's time (NRT_incref / NRT_decref under perf, 2026-12-04). The numbers are the same
bit for bit; a kernel that made an array would now fail to compile, not misbehave.
"""

from __future__ import annotations

from numba import njit
from numba.core import config

from core.kernels import Flavour
from device.compiled.cachedir import CACHE_DIR

if CACHE_DIR is not None:
    config.CACHE_DIR = str(CACHE_DIR)


def _jit(function):
    return njit(cache=CACHE_DIR is not None, nogil=True, error_model="numpy",
                _nrt=False)(function)


COMPILED = Flavour(wrap=_jit)


def compiled(function):
    """The compiled `function` (a kernel): one dispatcher per kernel per process."""
    return COMPILED.of(function)
