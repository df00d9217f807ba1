"""The trial file's `/emg` group: surface EMG beside the robot's samples (docs/data-format.md,
"EMG").

EMG has its own rate (about 1926 Hz for a Delsys Trigno, against the loop's 500 Hz), so
it is its own group with its own time stamps, already on the trial's clock:
`/emg/time` is trial time in s (the clock of `/timeseries/time`; negative before the
trial started), `/emg/samples` the raw EMG in V, `/emg/channels` one row per electrode
with the muscle under it, and `/emg/mvc/<muscle>` each muscle's MVC for the session
with its quality flags. Written to a closed trial file (after the recorder closed it,
like `/metrics`), checksummed like every other dataset.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np

from device.errors import RecordingError
from device.recording.trialfile import STATUS_RECORDING, open_for_update, utc_now_iso

GROUP = "emg"
CHUNK_ROWS = 4096  # about 2 s at the Trigno's rate
_CHANNEL_DTYPE = np.dtype([
    ("name", h5py.string_dtype()),
    ("muscle", h5py.string_dtype()),
    ("units", h5py.string_dtype()),
])


@dataclass(frozen=True, slots=True, eq=False)
class EmgGroup:
    """A trial file's `/emg` group in memory."""

    names: tuple[str, ...]
    muscles: tuple[str, ...]
    rate_hz: float
    time_s: np.ndarray  # (M,) trial time
    samples: np.ndarray  # (M, C) V
    attrs: dict
    mvc: dict[str, dict]  # muscle -> value_V, flags, reasons, …

    def channel_of(self, muscle: str) -> int:
        return self.muscles.index(muscle)


def write_emg(
    path: str | os.PathLike,
    *,
    names: Sequence[str],
    muscles: Sequence[str],
    rate_hz: float,
    time_s,
    samples,
    source: str,
    clock: str,
    offset_s: float,
    source_file: str = "",
    replace: bool = False,
) -> None:
    """Store EMG in a closed trial file's `/emg` group. `time_s` is already trial time;
    `clock` says in words how it was mapped, `offset_s` the shift applied (trial time =
    source time + offset_s). Refuses a file being recorded, and replacing EMG unless
    `replace`."""
    t = np.asarray(time_s, dtype=np.float64)
    x = np.asarray(samples, dtype=np.float64)
    if x.ndim != 2 or x.shape != (t.size, len(names)) or len(muscles) != len(names):
        raise RecordingError(f"EMG of shape {x.shape} with {t.size} times, {len(names)} names "
                             f"and {len(muscles)} muscles do not fit together")
    path = Path(path)
    try:
        # room for the arrays, their checksums and the group's metadata
        with open_for_update(path, reserve_bytes=t.nbytes + x.nbytes + 2**20) as f:
            _check_closed(f, path)
            if GROUP in f:
                if not replace:
                    raise RecordingError(f"{path.name} already has EMG; replace it explicitly "
                                         "(rehab emg import --replace)")
                del f[GROUP]
            group = f.create_group(GROUP)
            group.attrs.update({
                "sampling_rate_hz": float(rate_hz), "units": "V", "source": source,
                "source_file": source_file, "clock": clock, "offset_s": float(offset_s),
                "imported_utc": utc_now_iso(), "n_samples": np.int64(t.size),
            })
            rows = max(1, min(CHUNK_ROWS, t.size))
            time_ds = group.create_dataset("time", data=t, chunks=(rows,), fletcher32=True)
            time_ds.attrs["units"] = "s"
            time_ds.attrs["description"] = ("trial time of each EMG sample "
                                            "(clock of /timeseries/time)")
            data = group.create_dataset("samples", data=x, chunks=(rows, x.shape[1]),
                                        fletcher32=True)
            data.attrs["units"] = "V"
            data.attrs["description"] = "raw surface EMG, one column per row of /emg/channels"
            table = np.empty(len(names), dtype=_CHANNEL_DTYPE)
            for i, (name, muscle) in enumerate(zip(names, muscles, strict=True)):
                table[i] = (name, muscle, "V")
            group.create_dataset("channels", data=table)
    except (OSError, ValueError) as exc:
        raise RecordingError(f"cannot store EMG in {path}: {exc}") from exc


def write_mvc(path: str | os.PathLike, values: Mapping[str, Mapping]) -> None:
    """Store (or replace) MVCs in `/emg/mvc/<muscle>`: each a mapping of value_V, flags,
    reasons and whatever else describes it (numbers, strings; lists and dicts as JSON)."""
    path = Path(path)
    try:
        with open_for_update(path) as f:
            _check_closed(f, path)
            if GROUP not in f:
                raise RecordingError(f"{path.name} has no EMG; import the trial's EMG first "
                                     "(rehab emg import)")
            mvc = f[GROUP].require_group("mvc")
            for muscle, entry in values.items():
                if muscle in mvc:
                    del mvc[muscle]
                group = mvc.create_group(muscle)
                for key, value in entry.items():
                    if isinstance(value, list | tuple | dict):
                        group.attrs[key] = json.dumps(value)
                    elif value is None:
                        group.attrs[key] = "null"
                    else:
                        group.attrs[key] = value
    except (OSError, ValueError) as exc:
        raise RecordingError(f"cannot store the MVC in {path}: {exc}") from exc


def read_emg(path: str | os.PathLike) -> EmgGroup | None:
    """The `/emg` group of a trial file, or None when it has none."""
    path = Path(path)
    try:
        with h5py.File(path, "r", locking=False) as f:
            if GROUP not in f:
                return None
            group = f[GROUP]
            table = group["channels"][()]
            mvc = {}
            for muscle, entry in group.get("mvc", {}).items():
                mvc[muscle] = {k: _attr(v) for k, v in entry.attrs.items()}
            return EmgGroup(
                tuple(_text(r["name"]) for r in table), tuple(_text(r["muscle"]) for r in table),
                float(group.attrs["sampling_rate_hz"]), group["time"][()],
                group["samples"][()], {k: _attr(v) for k, v in group.attrs.items()}, mvc)
    except (OSError, KeyError, ValueError) as exc:
        raise RecordingError(f"cannot read the EMG of {path}: {exc}") from exc


def _check_closed(f: h5py.File, path: Path) -> None:
    if f.attrs.get("status") == STATUS_RECORDING:
        raise RecordingError(f"{path.name} is still being recorded; add EMG after it closes")


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _attr(value):
    if isinstance(value, bytes):
        value = value.decode()
    if isinstance(value, str) and value[:1] in "[{n":
        try:
            return json.loads(value)
        except ValueError:
            return value
    if isinstance(value, np.generic):
        return value.item()
    return value
