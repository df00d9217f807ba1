"""What a trial file's contents must be, whoever wrote them (docs/data-format.md, "What a
reader checks"): a reader refuses, in one line naming the dataset, what no trial the
console records can hold, so an edited or damaged file never loads as different data.

* Each channel's dataset matches its row of the channel table (type, width) and, for a
  channel the console records (device.recording.record.CHANNELS), the console's own
  definition: positions int32, (N, 3), 1-D or text were loaded before.
* Codes hold codes: `phase` 0-3 (device.loop.pipeline), `state` a loop state
  (device.loop.states), `fault` a fault code (device.safety.faults), the flags 0 or 1;
  `assistance_level` 0-1 or NaN. A phase of 7 or a fault of 65535 was loaded before.
* `tick` whole numbers from 0 that only increase, `time` finite seconds that only increase.
* The root attributes `parameters` and `subject`, when present, JSON objects.
"""

from __future__ import annotations

import json
from collections.abc import Mapping

import h5py
import numpy as np

from device.loop.pipeline import PHASE_EXERCISE, PHASE_HOLD, PHASE_IDLE
from device.loop.states import State
from device.recording.record import CHANNELS_BY_NAME
from device.recording.trialfile.verify import Damaged
from device.safety.faults import Fault

CODES: dict[str, frozenset[int]] = {
    "phase": frozenset(range(PHASE_IDLE, PHASE_HOLD + 1)),
    "state": frozenset(int(s) for s in State),
    "fault": frozenset(int(f) for f in Fault),
    "assistance_active": frozenset({0, 1}),
    "singular": frozenset({0, 1}),
}
"""The values a code channel can hold; PHASE_EXERCISE is among the phases."""
assert PHASE_EXERCISE in CODES["phase"]


def check_channel_datasets(table: np.ndarray, datasets: Mapping[str, h5py.Dataset],
                           text) -> None:
    """Every channel's dataset as its table row and the console's definition say (Damaged
    otherwise); `text` decodes the table's strings."""
    rows = {text(row["name"]): row for row in table}
    for name, dataset in datasets.items():
        dtype, shape = dataset.dtype, dataset.shape or ()
        where = f"/timeseries/{name}"
        if dtype.kind not in "iuf" or dtype.names or len(shape) not in (1, 2):
            raise Damaged(f"is damaged: {where} holds {_shape_text(dtype, shape)}, not a "
                          "number per sample")
        width = 1 if len(shape) == 1 else shape[1]
        row = rows.get(name)
        if row is not None:
            stated_width = int(row["width"])
            stated_dtype = text(row["dtype"])
            if np.dtype(dtype).str != _dtype_or_none(stated_dtype) or width != stated_width \
                    or (stated_width == 1) != (len(shape) == 1):
                raise Damaged(f"is damaged: {where} holds {_shape_text(dtype, shape)}, but the "
                              f"channel table says {stated_dtype} of width {stated_width}")
        known = CHANNELS_BY_NAME.get(name)
        if known is not None and (np.dtype(dtype) != np.dtype(known.dtype)
                                  or width != known.width
                                  or (known.width == 1) != (len(shape) == 1)):
            raise Damaged(f"is damaged: {where} holds {_shape_text(dtype, shape)}; the console "
                          f"records it as {np.dtype(known.dtype)} of width {known.width}")


def _dtype_or_none(text: str) -> str | None:
    try:
        return np.dtype(text).str
    except (TypeError, ValueError):
        return None


def _shape_text(dtype: np.dtype, shape: tuple) -> str:
    rows = ", ".join(["N", *map(str, shape[1:])])
    return f"{dtype} of shape ({rows}{',' if len(shape) == 1 else ''})"


def check_samples(channels: Mapping[str, np.ndarray]) -> None:
    """The values every trial's samples satisfy (Damaged otherwise, naming the dataset and
    the first sample that breaks it)."""
    for name, allowed in CODES.items():
        values = channels.get(name)
        if values is None or values.size == 0:
            continue
        bad = ~np.isin(values, np.fromiter(allowed, dtype=np.int64))
        if bad.any():
            k = int(np.flatnonzero(bad.reshape(len(values), -1).any(axis=1))[0])
            raise Damaged(f"is damaged: /timeseries/{name} is {values[k]} at sample {k}, which "
                          f"is no {name} code (allowed: {_allowed(allowed)})")
    level = channels.get("assistance_level")
    if level is not None and level.size:
        bad = ~(np.isnan(level) | ((level >= 0.0) & (level <= 1.0)))
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            raise Damaged(f"is damaged: /timeseries/assistance_level is {level[k]} at sample "
                          f"{k}; a level is 0-1 (NaN while no trial runs)")
    for name in ("tick", "time"):
        values = channels.get(name)
        if values is None or values.size == 0:
            continue
        if values.ndim != 1 or values.dtype.kind not in ("iu" if name == "tick" else "f"):
            raise Damaged(f"is damaged: /timeseries/{name} holds {values.dtype} values, not "
                          + ("whole numbers" if name == "tick" else "seconds"))
        if name == "time" and not np.isfinite(values).all():
            bad = int(np.flatnonzero(~np.isfinite(values))[0])
            raise Damaged(f"is damaged: /timeseries/{name} is {values[bad]} at sample {bad}")
        if name == "tick" and values[0] < 0:
            raise Damaged(f"is damaged: /timeseries/{name} starts at {values[0]}, below 0")
        step = np.diff(values.astype(float) if name == "time" else values)
        if values.size > 1 and not (step > 0).all():
            bad = int(np.flatnonzero(~(step > 0))[0])
            raise Damaged(f"is damaged: /timeseries/{name} goes from {values[bad]} to "
                          f"{values[bad + 1]} at sample {bad + 1}; it only ever increases")


def _allowed(values: frozenset[int]) -> str:
    ordered = sorted(values)
    if ordered == list(range(ordered[0], ordered[-1] + 1)) and len(ordered) > 2:
        return f"{ordered[0]}-{ordered[-1]}"
    return ", ".join(map(str, ordered))


def json_object_attribute(attrs: Mapping, key: str):
    """The root attribute `key` as a JSON object; None when absent (the caller notes it);
    Damaged when it is there but no JSON object ("null", a number, broken text)."""
    if key not in attrs:
        return None
    raw = attrs[key]
    try:
        value = json.loads(raw) if isinstance(raw, str) else None
    except ValueError:
        value = None
    if not isinstance(value, dict):
        shown = raw if isinstance(raw, str) and len(raw) <= 40 else f"{str(raw)[:40]}…"
        raise Damaged(f"is damaged: its root attribute {key!r} is {shown!r}, not the JSON "
                      "object the console writes")
    return value
