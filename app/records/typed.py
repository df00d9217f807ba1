"""What a therapist types for the records, as the registry takes it: a clinical scale's
scores (a total, or KEY=VALUE scores) and a corrected field's value. One reading for the
command line (app.cli.clinical) and the window (ui.tabs.clinical_record); what cannot be
read is refused in one line (InvalidRecordError), the ranges are the registry's
(app.records.scales, app.records.registry.patients).

The command line takes a patient's fields by the registry's names in SI (kg, m); the
window's Correct row by the names and in the units the Registration tab shows them
(`FIELD_NAMES`, app.units.MEASUREMENT_UNITS: cm), `shown_value` saying them so."""

from __future__ import annotations

import math

from app.errors import InvalidRecordError
from app.records.registry.patients import CHOSEN, MEASURED, birth_years
from app.records.scales import (
    ARAT,
    ASHWORTH,
    FUGL_MEYER,
    FUGL_MEYER_PARTS,
    SCALE_LABELS,
    SCALE_MAXIMA,
)
from app.units import MEASUREMENT_UNITS

FIELD_NAMES = {"first_name": "First name", "last_name": "Last name",
               "birth_year": "Year of birth", "side": "Side trained", "sex": "Sex",
               "handedness": "Handedness", "body_mass_kg": "Body mass",
               "upper_arm_m": "Upper arm", "forearm_m": "Forearm", "shoulder_m": "Shoulder"}
"""A patient's fields as the Registration tab names them (its form, its Correct row)."""


def typed_scores(scale: str, scores: list[str]) -> dict:
    """The record_scale keywords for a scale as typed: one total, or KEY=VALUE scores
    (Fugl-Meyer parts A-D or items, ARAT subscales, Ashworth GROUP=GRADE)."""
    scores = [s for s in (t.strip() for t in scores) if s]
    pairs = [s for s in scores if "=" in s]
    name = SCALE_LABELS.get(scale, scale)  # the scale's name, as the form lists it
    if not pairs:
        if len(scores) != 1:
            raise InvalidRecordError(f"{name}: give one total or KEY=VALUE scores, not "
                                     f"{' '.join(scores) or 'nothing'}")
        return {"total": _whole(name, scores[0], SCALE_MAXIMA.get(scale))}
    if len(pairs) != len(scores):
        raise InvalidRecordError(f"{name}: give either one total or KEY=VALUE scores, "
                                 "not both")
    given: dict[str, str] = {}
    for pair in pairs:
        key, _, value = pair.partition("=")
        key = key.strip()
        if key in given:
            raise InvalidRecordError(f"{name}: {key} given twice")
        given[key] = value.strip()
    if scale == ASHWORTH:
        return {"grades": given}
    values = {key: _whole(f"{name} {key}", value) for key, value in given.items()}
    if scale == FUGL_MEYER and not set(values) <= set(FUGL_MEYER_PARTS):
        return {"items": values}
    if scale in (FUGL_MEYER, ARAT):
        return {"parts": values}
    raise InvalidRecordError(f"{SCALE_LABELS.get(scale, scale)} is one number; give it alone")


def _whole(what: str, text: str, highest: int | None = None) -> int:
    """`text` as a whole number, else one line naming `what` (a scale by its name, not
    its id: "fatigue = '3.5'" named the registry's key) and what to give."""
    try:
        return int(text.strip())
    except ValueError:
        give = f"; give a whole number from 0 to {highest}" if highest is not None else ""
        raise InvalidRecordError(f"{what}: {text!r} is not a whole number{give}") from None


def typed_value(field: str, text: str) -> object:
    """The value typed for a patient's `field` as the registry takes it, SI units (kg, m;
    a shoulder as X,Y); 'none' clears the field."""
    text = text.strip()
    if text.lower() == "none":
        return None
    if field == "birth_year":
        return _whole("birth_year", text)
    if field == "shoulder_m":
        try:
            x, y = (float(v) for v in text.split(","))
        except ValueError:
            raise InvalidRecordError(f"shoulder_m = {text!r}: give X,Y in m (e.g. "
                                     "-0.12,0.73)") from None
        return (x, y)
    if field.endswith(("_m", "_kg")):
        try:
            value = float(text)
        except ValueError:
            raise InvalidRecordError(f"{field} = {text!r} is not a number") from None
        if not math.isfinite(value):
            raise InvalidRecordError(f"{field} = {text!r} is not a finite number")
        return value
    return text


def typed_shown_value(field: str, text: str) -> object:
    """The value typed in the Correct row for a patient's `field`, in the unit the
    Registration tab shows it (cm, kg; a shoulder as x,y), as the registry takes it (SI);
    'none' clears the field. Refused in one line naming the field as the tab does and the
    unit it was typed in; a measurement outside its range (the registry's, MEASURED) too."""
    text = text.strip()
    name = FIELD_NAMES[field]
    if text.lower() == "none":
        return None
    if field == "birth_year":
        year, (first, last) = _whole(name, text), birth_years()
        if not first <= year <= last:
            raise InvalidRecordError(f"{name} {year}: give a year {first}-{last}, or none")
        return year
    if field in CHOSEN:
        words, _ = CHOSEN[field]
        if text.lower() not in words:
            raise InvalidRecordError(f"{name} {text!r}: give {' or '.join(words)}, or none")
        return text.lower()
    if field not in MEASURED:
        return text
    unit, factor = MEASUREMENT_UNITS[field]
    if field == "shoulder_m":
        try:
            x, y = (_number(name, v, unit) for v in text.split(","))
        except ValueError:
            raise InvalidRecordError(f"{name} {text!r}: give x,y in {unit} (e.g. "
                                     f"{-0.12 * factor:g},{0.73 * factor:g})") from None
        return (_in_range(field, x, unit, factor), _in_range(field, y, unit, factor))
    return _in_range(field, _number(name, text, unit), unit, factor)


def shown_value(field: str, value: object) -> str:
    """A patient's field's value (SI, or as the audit keeps it: a shoulder as [x, y]) as
    the Registration tab shows it: '31.0 cm', '(-12.0, 73.0) cm', 'female', 'none'."""
    if value is None:
        return "none"
    if field not in MEASUREMENT_UNITS:
        return str(value)
    unit, factor = MEASUREMENT_UNITS[field]
    if field == "shoulder_m":
        x, y = value
        return f"({x * factor:.1f}, {y * factor:.1f}) {unit}"
    return f"{value * factor:.1f} {unit}"


def _number(name: str, text: str, unit: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise InvalidRecordError(f"{name} {text.strip()!r} is not a number; give it in "
                                 f"{unit}") from None
    if not math.isfinite(value):
        raise InvalidRecordError(f"{name} {text.strip()!r} is not a finite number")
    return value


def _in_range(field: str, shown: float, unit: str, factor: float) -> float:
    """`shown` (in `unit`) in SI, when inside the registry's range of `field` (compared in
    SI, as the registry compares it: 15 cm is 0.15 m, not 0.15000000000000002)."""
    value = shown / factor
    (low, high), _, why = MEASURED[field]
    if not low <= value <= high:
        raise InvalidRecordError(
            f"{FIELD_NAMES[field]} {shown:g} {unit} is out of range: give {low * factor:g} "
            f"to {high * factor:g} {unit}{f' ({why})' if why else ''}, or none")
    return value
