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
import re

from app.errors import InvalidRecordError
from app.records.registry.patients import CHOSEN, MEASURED, birth_years
from app.records.scales import (
    ARAT,
    ARAT_SUBSCALES,
    ASHWORTH,
    ASHWORTH_GRADES,
    ASHWORTH_GROUPS,
    FUGL_MEYER,
    FUGL_MEYER_ITEMS,
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
    if scale == ASHWORTH and not pairs:
        raise InvalidRecordError(f"{name} has no total: give GROUP=GRADE for each muscle "
                                 f"group measured ({', '.join(ASHWORTH_GROUPS)}), the grade "
                                 f"one of {', '.join(ASHWORTH_GRADES)}")
    if not pairs:
        if len(scores) != 1:
            forms = f"a whole number from 0 to {SCALE_MAXIMA.get(scale)}"
            if scale in (FUGL_MEYER, ARAT):
                forms = f"one total ({forms}) or KEY=VALUE scores"
            raise InvalidRecordError(f"{name}: give {forms}, not "
                                     f"{' '.join(scores) or 'nothing'}")
        return {"total": _whole(name, scores[0], _score_range(SCALE_MAXIMA.get(scale)))}
    if len(pairs) != len(scores):
        raise InvalidRecordError(f"{name}: give either one total or KEY=VALUE scores, "
                                 "not both")
    given: dict[str, str] = {}
    for pair in pairs:
        key, _, value = pair.partition("=")
        key = key.strip()
        if not key:
            raise InvalidRecordError(f"{name}: {pair!r} has no KEY before '='; give "
                                     "KEY=VALUE scores")
        if key in given:
            raise InvalidRecordError(f"{name}: {key} given twice")
        given[key] = value.strip()
    if scale == ASHWORTH:
        return {"grades": given}
    values = {key: _whole(f"{name} {key}", value, _score_range(_highest(scale, key)))
              for key, value in given.items()}
    if scale == FUGL_MEYER and not set(values) <= set(FUGL_MEYER_PARTS):
        return {"items": values}
    if scale in (FUGL_MEYER, ARAT):
        return {"parts": values}
    raise InvalidRecordError(f"{SCALE_LABELS.get(scale, scale)} is one number; give it alone")


def _highest(scale: str, key: str) -> int | None:
    """The highest score of a scale's part, subscale or item `key` (None: not one)."""
    if scale == ARAT:
        return ARAT_SUBSCALES.get(key)
    if scale == FUGL_MEYER:
        items = {item.key: item.maximum for item in FUGL_MEYER_ITEMS}
        return FUGL_MEYER_PARTS.get(key, items.get(key))
    return None


_WHOLE = re.compile(r"[+-]?[0-9]+")
"""A whole number as typed: int() also reads '1_0' as 10 and other scripts' digits."""


def _score_range(highest: int | None) -> str:
    return "" if highest is None else f"give a whole number from 0 to {highest}"


def _whole(what: str, text: str, give: str = "") -> int:
    """`text` as a whole number, else one line naming `what` (a scale by its name, not
    its id: "fatigue = '3.5'" named the registry's key) and what to `give`."""
    if not _WHOLE.fullmatch(text.strip()):
        raise InvalidRecordError(f"{what}: {text.strip()!r} is not a whole number"
                                 + (f"; {give}" if give else ""))
    return int(text)


def typed_value(field: str, text: str) -> object:
    """The value typed on the command line for a patient's `field`, named and in the units
    as the registry keeps it (SI: kg, m; a shoulder as x,y), as the registry takes it;
    'none' clears the field. Refused in one line naming the field and what to give."""
    unit = MEASURED[field][1] if field in MEASURED else ""
    return _typed(field, text, field, unit, 1.0)


def typed_shown_value(field: str, text: str) -> object:
    """The value typed in the Correct row for a patient's `field`, in the unit the
    Registration tab shows it (cm, kg; a shoulder as x,y), as the registry takes it (SI);
    'none' clears the field. Refused in one line naming the field as the tab does and the
    unit it was typed in; a measurement outside its range (the registry's, MEASURED) too."""
    unit, factor = MEASUREMENT_UNITS.get(field, ("", 1.0))
    return _typed(field, text, FIELD_NAMES[field], unit, factor)


def _typed(field: str, text: str, name: str, unit: str, factor: float) -> object:
    """`text` for `field` as the registry takes it, `name` and `unit` (`factor` from SI)
    being how the one who typed it names the field and gave its value."""
    text = text.strip()
    if text.lower() == "none":
        return None
    if not text:  # an empty value is a slip (an unset shell variable), not a clearing
        raise InvalidRecordError(f"{name}: nothing given; give the new value, or none to "
                                 "clear it")
    if field == "birth_year":
        first, last = birth_years()
        give = f"give a year {first}-{last}, or none"
        year = _whole(name, text, give)
        if not first <= year <= last:
            raise InvalidRecordError(f"{name} {year}: {give}")
        return year
    if field in CHOSEN:
        words, _ = CHOSEN[field]
        if text.lower() not in words:
            raise InvalidRecordError(f"{name} {text!r}: give {' or '.join(words)}, or none")
        return text.lower()
    if field not in MEASURED:
        return text
    if field == "shoulder_m":
        parts = text.split(",")
        if len(parts) != 2:
            raise InvalidRecordError(f"{name} {text!r}: give x,y in {unit} (e.g. "
                                     f"{-0.12 * factor:g},{0.73 * factor:g})")
        return tuple(_measured(field, name, part, unit, factor) for part in parts)
    return _measured(field, name, text, unit, factor)


def _measured(field: str, name: str, text: str, unit: str, factor: float) -> float:
    """A measurement typed in `unit` (`factor` from SI) in SI, when it is a number inside
    the registry's range of `field` (compared in SI, as the registry compares it: 15 cm is
    0.15 m, not 0.15000000000000002)."""
    (low, high), _, why = MEASURED[field]
    give = f"give {low * factor:g} to {high * factor:g} {unit}{f' ({why})' if why else ''}, " \
           "or none"
    try:
        if "_" in text:  # float() reads '1_0' as 10
            raise ValueError(text)
        shown = float(text)
    except ValueError:
        raise InvalidRecordError(f"{name} {text.strip()!r} is not a number; {give}") from None
    if not math.isfinite(shown):
        raise InvalidRecordError(f"{name} {text.strip()!r} is not a finite number; {give}")
    value = shown / factor
    if not low <= value <= high:
        raise InvalidRecordError(f"{name} {shown:g} {unit} is out of range: {give}")
    return value


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
