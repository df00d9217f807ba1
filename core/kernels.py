"""Per-tick formulas written once, run three ways.

A *kernel* is a module-level function marked `@kernel`, written in the part of Python
that numba compiles: floats, ints and bools, tuples, indexing into flat vectors (a
tuple or list in Python, a float64 array when compiled), `if`/`for`/`while`, and the
math functions through the module-level name `xp`. The same code then runs

* **interpreted**, on plain floats: the reference, and what the object API
  (`RobotModel.mass_terms`, `SlidingModeController.step`, …) calls;
* **on numpy arrays** (`ARRAYS.of(f)`): the same code with `xp` bound to numpy and
  `where` to `numpy.where`, for whole recordings at once (only kernels whose branches
  are all `where` or on constants can take arrays);
* **compiled** by numba in the loop process (device.compiled builds that flavour with
  `Flavour(wrap=numba.njit(...))`): core itself never imports numba.

Why one body and not a fast copy beside a readable one: the copies drift. A kernel
calls other kernels by their bare names (imported with ``from core.x import f``), and
a flavour rebinds every such name, in a private copy of the module's globals, to the
flavoured callee; so each flavour is a consistent world and nothing is patched in the
real modules. Module-level numbers (the index names of a constants vector, `_TWO_PI`)
are read as they are when a flavour is first built, which numba folds into constants.
"""

from __future__ import annotations

import dis
import math
import types
from collections.abc import Callable, Mapping

import numpy as np

xp = math
"""The math namespace of kernels in this module (numpy in the ARRAYS flavour)."""


def kernel(function: Callable) -> Callable:
    """Mark `function` as a kernel (see the module notes). Returns it unchanged."""
    function.__kernel__ = True
    return function


def is_kernel(value) -> bool:
    return getattr(value, "__kernel__", False) is True and isinstance(value, types.FunctionType)


@kernel
def where(condition, if_true, if_false):
    """`if_true` where `condition` holds, else `if_false` (numpy.where on arrays). Both
    are evaluated: a kernel that must avoid one side's error guards it with its own
    `where` first."""
    return if_true if condition else if_false


class Flavour:
    """One way of running kernels: `of(f)` gives f with every kernel it calls (and the
    names in `replacements`) rebound in a private copy of each module's globals, and
    passed through `wrap` (numba.njit for the compiled flavour; none for the others)."""

    def __init__(self, replacements: Mapping[str, object] | None = None,
                 wrap: Callable[[Callable], Callable] | None = None) -> None:
        self._replacements = dict(replacements or {})
        self._wrap = wrap
        self._made: dict[int, Callable] = {}
        self._namespaces: dict[int, dict] = {}

    def of(self, function: Callable) -> Callable:
        """The flavoured `function` (a kernel); the same object on every call."""
        made = self._made.get(id(function))
        if made is not None:
            return made
        if not is_kernel(function):
            raise TypeError(f"{getattr(function, '__qualname__', function)!r} is not a @kernel")
        namespace = self._namespace(function.__globals__)
        copy = types.FunctionType(function.__code__, namespace, function.__name__,
                                  function.__defaults__, function.__closure__)
        copy.__qualname__ = function.__qualname__
        copy.__module__ = function.__module__
        copy.__doc__ = function.__doc__
        copy.__kernel__ = True
        made = self._wrap(copy) if self._wrap is not None else copy
        self._made[id(function)] = made
        # Callees are flavoured before the caller first runs: numba resolves a global
        # function when it compiles the caller, so it must already be the compiled one.
        for name in _global_names(function.__code__):
            if name in self._replacements:
                continue
            value = function.__globals__.get(name)
            if is_kernel(value):
                namespace[name] = self.of(value)
        for module, attribute in _module_attributes(function.__code__):
            # module.kernel(...) would run the module's own copy in every flavour
            if is_kernel(getattr(function.__globals__.get(module), attribute, None)):
                raise TypeError(
                    f"kernel {function.__qualname__} calls {module}.{attribute} through its "
                    "module; import it by name so each flavour can rebind it")
        return made

    def _namespace(self, module_globals: dict) -> dict:
        namespace = self._namespaces.get(id(module_globals))
        if namespace is None:
            namespace = dict(module_globals)
            namespace.update(self._replacements)
            self._namespaces[id(module_globals)] = namespace
        return namespace


def _module_attributes(code: types.CodeType) -> set[tuple[str, str]]:
    """(global, attribute) for every `global.attribute` the code reads."""
    found = set()
    previous = None
    for instruction in dis.get_instructions(code):
        if (previous is not None and previous.opname == "LOAD_GLOBAL"
                and instruction.opname in ("LOAD_ATTR", "LOAD_METHOD")):
            found.add((previous.argval, instruction.argval))
        previous = instruction
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            found |= _module_attributes(const)
    return found


def _global_names(code: types.CodeType) -> set[str]:
    names = set(code.co_names)
    for const in code.co_consts:
        if isinstance(const, types.CodeType):
            names |= _global_names(const)
    return names


ARRAYS = Flavour({"xp": np, "where": np.where})
"""Kernels on numpy arrays of any shape (element-wise), for whole recordings."""


def suited(function: Callable, value) -> Callable:
    """`function` as it must run for `value`: itself for plain numbers, its ARRAYS flavour
    for numpy arrays (what the models' methods use to take both)."""
    return ARRAYS.of(function) if isinstance(value, np.ndarray) else function


def interpreted(function: Callable, replacements: Mapping[str, object] | None = None):
    """`function` (a kernel) to run in Python: itself, or with `replacements` (plain
    Python in place of some kernel it calls, e.g. a patient's own torque) its own
    flavour."""
    if not replacements:
        return function
    return Flavour(replacements).of(function)
