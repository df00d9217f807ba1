"""The gains a researcher may set for a trial, as one line of text saved with it.

The thesis suggests raising the tracking gains, or the tolerance, when a patient never
pushes one way (section 3.6.1). A trial carries its changes to the default gains in
`TrialParameters.gains`, a line such as

    smc.lambda_1_s=25; smc.k_d_Nms_rad=3.5,4; guidance.delay_s=0.5

one `group.name=value` per change, `;` between them: the group is the controller's
(`smc`, `ctpid`), the as-needed mode's (`guidance`) or the transparent mode's
(`transparent`), the name a field of its gains (SMCGains, CTPIDGains, GuidanceGains,
TransparentGains), and a per-joint gain takes one number for both
joints or two separated by a comma. Every value is checked by the gains' own ranges and
refused by name. The line is kept in a canonical form (sorted, plain numbers), so equal
gains compare equal, and it is saved wherever the trial's parameters are (the registry,
the trial file's /parameters), so a trial's file says which gains ran it.
"""

from __future__ import annotations

import dataclasses
import math

from core.control.ctpid import CTPIDGains
from core.control.guidance import GAIN_RANGES, GuidanceGains
from core.control.smc import SMCGains
from core.control.transparent import TRANSPARENT_RANGES, TransparentGains
from core.errors import ParameterError

GAIN_TYPES = {"smc": SMCGains, "ctpid": CTPIDGains, "guidance": GuidanceGains,
              "transparent": TransparentGains}
"""The gain groups a trial's `gains` line may change, by name."""

_EXAMPLE = "group.name=value, e.g. smc.lambda_1_s=25 or guidance.delay_s=0.5"


def parse_gains(text: str) -> dict[str, dict[str, object]]:
    """{group: {field: value}} from a gains line; refuses an unknown group or field, a
    value that is not a number (or two), and a field given twice, by name."""
    if not isinstance(text, str):
        raise ParameterError("gains", text, "a line of text: " + _EXAMPLE)
    out: dict[str, dict[str, object]] = {}
    for entry in text.replace("\n", ";").split(";"):
        entry = entry.strip()
        if not entry:
            continue
        name, equals, value = entry.partition("=")
        group, dot, field = name.strip().partition(".")
        if not equals or not dot:
            raise ParameterError("gains", entry, _EXAMPLE)
        if group not in GAIN_TYPES:
            raise ParameterError("gains", entry, "a group of " + ", ".join(GAIN_TYPES),
                                 f"no gains called {group!r}")
        kind = GAIN_TYPES[group]
        fields = {f.name: f for f in dataclasses.fields(kind)}
        if field not in fields:
            raise ParameterError("gains", entry, f"a gain of {group}: " + ", ".join(fields))
        if field in out.get(group, {}):
            raise ParameterError("gains", entry, "each gain once", f"{name.strip()} is given twice")
        out.setdefault(group, {})[field] = _value(entry, value, fields[field].type)
    return out


def _value(entry: str, text: str, annotation) -> object:
    parts = [p.strip() for p in text.split(",")]
    try:
        numbers = [float(p) for p in parts]
    except ValueError:
        raise ParameterError("gains", entry, "a number, or two separated by a comma for a "
                             "per-joint gain") from None
    if not all(math.isfinite(v) for v in numbers):
        raise ParameterError("gains", entry, "finite numbers")
    pair = "tuple" in str(annotation)
    if pair:
        if len(numbers) == 1:
            numbers = numbers * 2
        if len(numbers) != 2:
            raise ParameterError("gains", entry, "one number for both joints, or two")
        return (numbers[0], numbers[1])
    if len(numbers) != 1:
        raise ParameterError("gains", entry, "one number (this gain is not per joint)")
    if annotation in (int, "int"):
        if not numbers[0].is_integer():
            raise ParameterError("gains", entry, "a whole number")
        return int(numbers[0])
    return numbers[0]


def built(group: str, text: str):
    """The gains of `group` with the line's changes, validated by their own ranges (a
    value out of range is refused as a gains error naming the gain)."""
    changes = parse_gains(text).get(group, {})
    try:
        return GAIN_TYPES[group](**changes)
    except ParameterError as exc:
        raise ParameterError("gains", f"{group}.{exc.field} = {exc.value}", exc.allowed,
                             exc.why) from None


def canonical_gains(text: str) -> str:
    """The line in canonical form (validated: every group it names is built)."""
    parsed = parse_gains(text)
    for group in parsed:
        built(group, text)
    entries = []
    for group in sorted(parsed):
        for field, value in sorted(parsed[group].items()):
            shown = ",".join(f"{v:g}" for v in value) if isinstance(value, tuple) else (
                f"{value:g}")
            entries.append(f"{group}.{field}={shown}")
    return "; ".join(entries)


def gain_rows() -> list[tuple[str, str, str, str]]:
    """(group.name, default, range and meaning, gains type) of every gain, for `rehab
    gains`."""
    rows = []
    for group, kind in GAIN_TYPES.items():
        default = kind()
        for f in dataclasses.fields(kind):
            value = getattr(default, f.name)
            shown = ",".join(f"{v:g}" for v in value) if isinstance(value, tuple) else (
                f"{value:g}")
            meaning = f"per joint (joint 1, joint 2): {kind.__module__}'s notes"
            ranges = {"guidance": GAIN_RANGES, "transparent": TRANSPARENT_RANGES}.get(group)
            if ranges is not None:
                low, high, unit, why = ranges[f.name]
                meaning = f"{low:g}–{high:g} {unit}".strip() + f": {why}"
            rows.append((f"{group}.{f.name}", shown, meaning, kind.__name__))
    return rows
