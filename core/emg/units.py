"""Units of an EMG voltage, as instruments write them: in file headers (Delsys exports,
`biceps [mV]`), in an LSL stream's channel description (`microvolts`, the XDF meta-data
convention) and in XDF recordings. Everything inside the console is in volts.

An amplifier that sends its converter's raw integers says what one count is worth beside
the unit: `desc/channels/channel/scaling_factor`, the value in `unit` being the stored
number times the factor (Brain Products' BrainAmp and LiveAmp LSL apps send int16 counts
with unit `microvolts` and factor 0.1, 0.5, 10 or 152.6, their resolution; their float
streams, already scaled, say 1). A channel without one is stored in its unit as it is."""

from __future__ import annotations

import math

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


def scaling_factor(text: str) -> float | None:
    """A channel's declared `scaling_factor` (module docstring): 1.0 when none is written,
    None when what is written is not a positive finite number."""
    if not text.strip():
        return 1.0
    try:
        value = float(text)
    except ValueError:
        return None
    return value if math.isfinite(value) and value > 0 else None
