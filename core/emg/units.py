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


EMG_TYPES = frozenset({"", "emg", "exg", "eeg", "bipolar", "aux"})
"""Channel types (`desc/channels/channel/type`, lower case) whose voltage is taken as EMG:
none declared; EMG; ExG and EEG, what Brain Products' BrainAmp and LiveAmp apps call every
electrode channel (a BrainAmp ExG or a LiveAmp's bipolar inputs carry the EMG); `bipolar`
and `AUX`, the LiveAmp's bipolar and auxiliary inputs (its BIP2AUX adapter puts a bipolar
EMG lead on an AUX input)."""

TRIGGER_UNITS = frozenset({"code", "codes"})
"""Units of a trigger channel: BrainAmpSeries' `triggerStream` says `code` (and type EEG)."""

_TRIGGER_WORDS = ("trigger", "marker")
"""In a channel's type or label: LiveAmp's `Markers` (type Markers, no unit),
`STETriggerIn`/`STETriggerOut` (unit `integer`), BrainAmpSeries' `triggerStream`."""


def trigger_channel(label: str, kind: str, unit: str) -> str | None:
    """Why a channel that is not a voltage is the trigger or marker channel an amplifier's
    LSL app appends to its data stream (BrainAmpSeries' `triggerStream` of unit `code`,
    LiveAmp's `Markers` and `STETrigger…`), or None when it is not one. Such a channel
    carries event codes, -1 between them, never EMG; a voltage channel is never one."""
    if volts_per_unit(unit) is not None:
        return None
    if unit.strip().lower() in TRIGGER_UNITS:
        return f"a trigger channel (unit {unit!r})"
    for what, text in (("type", kind), ("label", label)):
        if any(word in text.lower() for word in _TRIGGER_WORDS):
            return f"a trigger/marker channel ({what} {text!r})"
    return None


def emg_type(kind: str) -> bool:
    """Whether a channel's declared type is one whose voltage is EMG (EMG_TYPES)."""
    return kind.strip().lower() in EMG_TYPES
