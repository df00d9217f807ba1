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
"""In a channel's type or label: LiveAmp's `DeviceTrigger` and `STETriggerIn` (type
Trigger, unit `integer`; `Markers` in its older versions), BrainAmpSeries'
`triggerStream`."""

SENSOR_TYPES = {
    "acc": "an accelerometer",
    "samplecounter": "a sample counter",
    "syncpulse": "a sync pulse",
}
"""Channel types (lower case) an amplifier's LSL app declares for what it appends beside
the electrodes, none of them EMG: the LiveAmp app's `ACC_X/Y/Z` (type ACC, unit milliGs;
its shipped configuration enables them, `useACC=true`), `SampleCounter` (type
SampleCounter) and, with its STE box in Sync mode, `STESync` (type SyncPulse, unit
integer); the actiCHamp connector's `SampleCounter` too (brain-products/LSL-LiveAmp,
mainwindow.cpp, where the stream's channels are described)."""


def not_emg_channel(label: str, kind: str, unit: str) -> str | None:
    """Why a channel an amplifier's LSL app appends to its data stream is not EMG, in
    words, or None when it may be. A trigger or marker channel (BrainAmpSeries'
    `triggerStream` of unit `code`, LiveAmp's `DeviceTrigger`, `Markers`, `STETrigger…`)
    carries event codes, -1 between them; a voltage channel is never one. A channel of a
    declared sensor type (SENSOR_TYPES: an accelerometer, a sample counter, a sync pulse)
    is left out whatever its unit. A channel of any other type or unit is not named here:
    the caller refuses it unless it is an EMG voltage (a mislabelled electrode is said,
    never dropped)."""
    sensor = SENSOR_TYPES.get(kind.strip().lower())
    if sensor is not None:
        return f"{sensor} (type {kind.strip()!r})"
    if volts_per_unit(unit) is not None:
        return None
    if unit.strip().lower() in TRIGGER_UNITS:
        return f"a trigger channel of event codes (unit {unit!r})"
    for what, text in (("type", kind), ("label", label)):
        if any(word in text.lower() for word in _TRIGGER_WORDS):
            return f"a trigger/marker channel of event codes ({what} {text!r})"
    return None


def left_out_notes(what: str, left_out: list[str]) -> tuple[str, ...]:
    """The one line that names the channels not_emg_channel left out of `what` (none: no
    line)."""
    return (f"left out of {what}, not EMG: {'; '.join(left_out)}",) if left_out else ()


def emg_type(kind: str) -> bool:
    """Whether a channel's declared type is one whose voltage is EMG (EMG_TYPES)."""
    return kind.strip().lower() in EMG_TYPES
