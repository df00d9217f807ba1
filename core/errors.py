"""The one exception family of `core`.

Every message says what is wrong, where (the field or the point), the allowed
range, and what to do, so a therapist can act on it without a manual.
"""

from __future__ import annotations

import math

import numpy as np


class CoreError(Exception):
    """Base of every error raised by `core`."""


class ParameterError(CoreError, ValueError):
    """A parameter is missing, not finite, or outside its allowed range."""

    def __init__(self, field: str, value: object, allowed: str, why: str = "") -> None:
        self.field = field
        self.value = value
        self.allowed = allowed
        self.why = why
        text = f"{field} = {_show(value)} is not allowed; allowed: {allowed}"
        if why:
            text += f" ({why})"
        super().__init__(text)


class UnreachableError(CoreError, ValueError):
    """A point or a path lies outside what the robot or the subject's arm can reach."""


class SingularityError(CoreError, ArithmeticError):
    """A Jacobian or mass matrix is singular where an inverse was required."""


def capitalised(text: str) -> str:
    """`text` begun with a capital, as a sentence that starts with it (the rest as is: a
    clause written to follow other words, such as a refusal's reason). Every layer's
    one-line messages build their sentences with it."""
    return text[:1].upper() + text[1:]


def _show(value: object) -> str:
    if isinstance(value, float):
        return "NaN" if math.isnan(value) else f"{value:g}"
    return repr(value)


def check_finite(field: str, value: float, unit: str = "") -> float:
    """Return `value` as a float, refusing NaN, infinities and non-numbers."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ParameterError(field, value, f"a finite number{_unit(unit)}") from None
    if not math.isfinite(number):
        raise ParameterError(field, number, f"a finite number{_unit(unit)}")
    return number


def as_number(name: str, value: object) -> float:
    """`value` as a plain float when it is a number (numpy's included: they reach JSON and
    HDF5 attributes as floats); a string or a flag is refused by name."""
    if isinstance(value, bool | np.bool_) or not isinstance(value, int | float | np.integer
                                                            | np.floating):
        raise ParameterError(name, value, "a number", "give it as a number, not as text")
    return float(value)


def check_whole(name: str, value: object, low: int, high: int) -> None:
    """Refuse a `value` that is not a whole number (a flag is not one) in [low, high]."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer):
        raise ParameterError(name, value, f"a whole number in [{low}, {high}]")
    check_range(name, value, low, high)


def check_range(
    field: str,
    value: float,
    low: float,
    high: float,
    unit: str = "",
    why: str = "",
    *,
    low_open: bool = False,
) -> float:
    """Return `value` when it is finite and inside [low, high] (or (low, high])."""
    allowed = f"{'(' if low_open else '['}{low:g}, {high:g}]{_unit(unit)}"
    try:
        number = check_finite(field, value, unit)
    except ParameterError:
        # NaN, inf or no number: the range to give too, not only 'a finite number'
        raise ParameterError(field, value, f"a finite number in {allowed}", why) from None
    below = number <= low if low_open else number < low
    if below or number > high:
        raise ParameterError(field, number, allowed, why)
    return number


def check_positive(field: str, value: float, unit: str = "", why: str = "") -> float:
    """Return `value` when it is finite and strictly positive."""
    number = check_finite(field, value, unit)
    if number <= 0.0:
        raise ParameterError(field, number, f"> 0{_unit(unit)}", why)
    return number


def check_non_negative(field: str, value: float, unit: str = "", why: str = "") -> float:
    """Return `value` when it is finite and zero or positive."""
    number = check_finite(field, value, unit)
    if number < 0.0:
        raise ParameterError(field, number, f">= 0{_unit(unit)}", why)
    return number


def _unit(unit: str) -> str:
    return f" {unit}" if unit else ""
