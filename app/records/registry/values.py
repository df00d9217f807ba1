"""What the registry accepts and how it stores it: checks of the texts, numbers and times
given for patients, sessions and trials, and the JSON text of parameters and metrics.

Parameters and metrics are JSON text, so a new metric needs no schema change.
JSON has no NaN: an undefined metric is stored as null and read back as NaN.
Times are stored as UTC ISO text with microseconds.
"""

from __future__ import annotations

import datetime
import json
import math
import re
from collections.abc import Iterable, Mapping

import orjson

from app.errors import InvalidRecordError
from core.errors import CoreError
from core.trial import TrialParameters
from core.work import drop_old_share

NAME_MAX_CHARS = 100
TEXT_MAX_CHARS = 10_000

_METRIC_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]{0,63}")


def checked_text(name: str, value: object, max_chars: int) -> str:
    """`value` stripped, refused unless it is text of at most `max_chars` characters
    without a NUL character. NUL is refused on both engines: PostgreSQL cannot store it in
    text (SQLite can), and a registry must hold the same texts on either engine (a record
    copied to the server must be storable there). It only ever comes pasted from a binary
    source."""
    if not isinstance(value, str):
        raise InvalidRecordError(f"{name}: give text, not {type(value).__name__}")
    value = value.strip()
    if "\0" in value:
        raise InvalidRecordError(f"{name} holds a NUL character (\\0, at character "
                                 f"{value.index(chr(0)) + 1}), which no registry stores: "
                                 "type it again without it")
    try:
        value.encode("utf-8")
    except UnicodeEncodeError:
        raise InvalidRecordError(f"{name} holds bytes that are not text (UTF-8); type it "
                                 "again") from None
    if len(value) > max_chars:
        raise InvalidRecordError(f"{name} has {len(value)} characters; keep it to {max_chars}")
    return value


def check_number(name: str, number: object) -> None:
    """Refuse a session or trial number that is not a whole number from 1 to 999999."""
    if isinstance(number, bool) or not isinstance(number, int) or not 1 <= number <= 999_999:
        raise InvalidRecordError(f"{name} {number!r}: give a whole number from 1 to 999999")


def utc_now() -> datetime.datetime:
    return datetime.datetime.now(datetime.UTC)


def utc_text(moment: datetime.datetime) -> str:
    return moment.astimezone(datetime.UTC).isoformat(timespec="microseconds")


def aware(moment: datetime.datetime, name: str) -> datetime.datetime:
    """`moment`, refused unless it is a datetime with a time zone."""
    if not isinstance(moment, datetime.datetime) or moment.tzinfo is None:
        raise InvalidRecordError(
            f"{name} {moment!r}: give a datetime with a time zone (e.g. datetime.UTC)"
        )
    return moment


def parameters_dict(parameters: TrialParameters | Mapping) -> dict:
    """Trial parameters as stored: validated, as `TrialParameters.to_dict()`."""
    if isinstance(parameters, TrialParameters):
        return parameters.to_dict()
    if not isinstance(parameters, Mapping):
        raise InvalidRecordError("parameters: give a core.trial.TrialParameters")
    try:
        return TrialParameters.from_dict(dict(parameters)).to_dict()
    except (CoreError, TypeError) as exc:
        raise InvalidRecordError(f"trial parameters refused: {exc}") from None


def metrics_json(metrics: Mapping[str, float]) -> str:
    """Metrics as stored: names checked, numbers as floats, NaN and infinities as null."""
    if not isinstance(metrics, Mapping):
        raise InvalidRecordError("metrics: give a mapping of metric names to numbers")
    out = {}
    for name, value in metrics.items():
        if not isinstance(name, str) or not _METRIC_NAME.fullmatch(name):
            raise InvalidRecordError(
                f"metric name {name!r}: use letters, digits and '_', with the units in it "
                "(e.g. rmse_x_m)"
            )
        if isinstance(value, bool) or not isinstance(value, int | float):
            try:
                value = float(value)  # numpy scalars
            except (TypeError, ValueError):
                raise InvalidRecordError(
                    f"metric {name} = {value!r}: give a number (NaN if undefined)"
                ) from None
        value = float(value)
        out[name] = value if math.isfinite(value) else None
    return json.dumps(out, allow_nan=False)


def metrics_json_ready(metrics: Mapping[str, float]) -> dict:
    """Metrics read back (NaN where undefined) made storable again (null)."""
    return {k: v if math.isfinite(v) else None for k, v in metrics.items()}


def parse_metrics(texts: Iterable[str]) -> list[dict[str, float]]:
    """Stored metrics back to floats; JSON has no NaN, so undefined ones are null.

    orjson, not the standard json: a patient's 1,000 trials hold 1.4 MB of metrics, which
    json.loads parsed in 20 ms of the progress query's 42 (bench/registry.py) and orjson in
    3.5. The text is what metrics_json wrote (json.dumps, allow_nan=False), which both read
    alike. The nulls become NaN in place: rebuilding each dict cost another 8 ms."""
    parsed = orjson.loads("[" + ",".join(texts) + "]")
    nan = math.nan
    for values in parsed:
        drop_old_share(values)
        if None in values.values():
            for name in [k for k, v in values.items() if v is None]:
                values[name] = nan
    return parsed
