"""What a new trial file holds before its first sample: the header's attributes (the
trial's parameters, subject, robot and sampling), the parameter group, the channel table,
the empty channel datasets and event table, and the header's own seal. Written by
`TrialFileWriter` (device.recording.trialfile.writer) before the file switches to SWMR,
which allows no new attribute or dataset; the layout is docs/data-format.md's.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import h5py
import numpy as np

from core.trial import TrialParameters
from device.errors import RecordingError
from device.recording.record import Channel
from device.recording.trialfile import seal
from device.recording.trialfile.layout import (
    EVENT_CHUNK_ROWS,
    EVENT_DTYPE,
    FORMAT_NAME,
    FORMAT_VERSION,
    STATUS_RECORDING,
    SubjectInfo,
    _create_channel_dataset,
    _plain_mapping,
    _to_json,
    _write_channel_table,
    _write_parameter_group,
    software_version,
    utc_now_iso,
)


def check_header(sample_period_s: object, parameters: object, subject: object) -> None:
    """Refuse a header that could not describe the trial, before a file exists."""
    if not (isinstance(sample_period_s, int | float) and math.isfinite(sample_period_s)
            and sample_period_s > 0):
        raise RecordingError(
            f"sample_period_s = {sample_period_s!r}: give the loop period in s (> 0)"
        )
    if not isinstance(parameters, TrialParameters):
        raise RecordingError("parameters must be a core.trial.TrialParameters")
    if not isinstance(subject, SubjectInfo):
        raise RecordingError("subject must be a device.recording.trialfile.SubjectInfo")


def header_attributes(parameters: TrialParameters, subject: SubjectInfo,
                      robot: Mapping | object, backend: str, sample_period_s: float) -> dict:
    """The file's attributes as a new trial file starts: status 'recording'."""
    robot_json = _to_json("robot", _plain_mapping(robot))  # refused first, as it always was
    return {
        "format": FORMAT_NAME,
        "format_version": np.int64(FORMAT_VERSION),
        "software_version": software_version(),
        "h5py_version": h5py.version.version,
        "hdf5_version": h5py.version.hdf5_version,
        "created_utc": utc_now_iso(),
        "sample_period_s": float(sample_period_s),
        "backend": str(backend),
        "parameters": _to_json("parameters", parameters.to_dict()),
        "subject": _to_json("subject", subject.to_dict()),
        "robot": robot_json,
        "status": STATUS_RECORDING,
    }


def write_header(f: h5py.File, header: Mapping, parameters: TrialParameters,
                 channels: tuple[Channel, ...], chunk_rows: int):
    """Write `header` (header_attributes) and the empty tables into the new file `f`, then
    the header's seal; return the channels' datasets, as (name, low-level dataset id,
    shape of one sample beyond the first axis), and the events' dataset."""
    for name, value in header.items():
        f.attrs[name] = value
    _write_parameter_group(f.create_group("parameters"), parameters.to_dict())
    _write_channel_table(f, channels)
    series = f.create_group("timeseries")
    # Low-level dataset ids: h5py's slicing costs ~40 µs a call in Python, and
    # every batch makes two calls per channel.
    datasets = [
        (c.name, _create_channel_dataset(series, c, chunk_rows).id,
         () if c.width == 1 else (c.width,))
        for c in channels
    ]
    events = f.create_dataset(
        "events", shape=(0,), maxshape=(None,), dtype=EVENT_DTYPE,
        chunks=(EVENT_CHUNK_ROWS,), fletcher32=True,
    )
    # before SWMR, which allows no new attribute: a crashed trial's metadata verify
    seal.write_header_seal(f)
    return datasets, events
