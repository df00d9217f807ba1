"""Units of an EMG voltage, as instruments write them: in file headers (Delsys exports,
`biceps [mV]`), in an LSL stream's channel description (`microvolts`, the XDF meta-data
convention) and in XDF recordings. Everything inside the console is in volts."""

from __future__ import annotations

VOLTS_PER_UNIT = {
    "v": 1.0, "volt": 1.0, "volts": 1.0,
    "mv": 1e-3, "millivolt": 1e-3, "millivolts": 1e-3,
    "uv": 1e-6, "\u00b5v": 1e-6, "\u03bcv": 1e-6, "microvolt": 1e-6, "microvolts": 1e-6,
    "nv": 1e-9, "nanovolt": 1e-9, "nanovolts": 1e-9,
}
"""Lower case, spaces removed; µ as the micro sign (U+00B5) or the Greek mu (U+03BC)."""


def volts_per_unit(unit: str) -> float | None:
    """Volts in one `unit`, or None when it is not a voltage written in one of the ways
    above."""
    return VOLTS_PER_UNIT.get(unit.strip().lower().replace(" ", ""))
