"""What a therapist types for the records, as the registry takes it: a clinical scale's
scores (a total, or KEY=VALUE scores) and a corrected field's value. One reading for the
command line (app.cli.clinical) and the window (ui.tabs.clinical_record); what cannot be
read is refused in one line (InvalidRecordError), the ranges are the registry's
(app.records.scales, app.records.registry.patients)."""

from __future__ import annotations

import math

from app.errors import InvalidRecordError
from app.records.scales import (
    ARAT,
    ASHWORTH,
    FUGL_MEYER,
    FUGL_MEYER_PARTS,
    SCALE_LABELS,
    SCALE_MAXIMA,
)


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
