"""MATLAB export of one trial: a compressed v5 `.mat` file with the HDF5 file's names.

Variables (`S = load('trial.mat')`):

==============  =================================================================
``timeseries``  struct, one field per channel: N×1 or N×width, one row per sample,
                in the trial file's own type (double, single, int64, uint8, uint16),
                so no transpose is needed (unlike h5read)
``channels``    struct of columns, as ``h5read(f, '/channels')`` gives it: ``name``,
                ``field`` (the struct field of each channel), ``width``, ``dtype``,
                ``units``, ``frame``, ``description``
``units``       struct: channel field → units text (``m``, ``rad/s``, ``N*m``, ``1``)
``frames``      struct: channel field → frame text
``parameters``  struct: the trial parameters (points as 1×2 [x y], flags as logical)
``metrics``     struct: metric → double (NaN = undefined), the figures the registry
                stands by (app.exports.figures)
``metrics_recorded``  struct: the trial file's own figures, as recorded; they differ
                from ``metrics`` only after `rehab reanalyse` re-computed them
``events``      struct of columns: ``time_s``, ``tick`` (E×1), ``kind``, ``message``,
                ``values`` (E×1 cell arrays of text; ``values`` holds JSON:
                ``jsondecode(S.events.values{i})``)
``subject``     struct: ``code``, ``body_mass_kg``, ``upper_arm_m``, ``forearm_m``,
                ``side``
``summary``     struct: the file's /summary attributes
``attributes``  struct: the file's root attributes as stored (parameters, subject and
                robot as JSON text)
``export``      struct: ``source_file``, ``rows`` ('all' or 'exercise'),
                ``exported_utc``, ``software_version``, ``metrics_source``
                ('recorded' or 'registry': whose figures ``metrics`` are) and, from a
                registry, ``invalid_reason`` (why it marks the trial invalid; '' if not)
``assistance``  struct, when the file has the group: the mode, level and gains, and
                ``feedforward_N`` (repetitions × bins)
``pose``        struct, when ``rehab pose`` ran: the camera's keypoints per frame and its
                angles, shoulder and drift per sample, as in the file's /pose
``emg``         struct, when the trial has EMG: ``time``, ``samples``, ``channels``
                (columns) and ``mvc`` (one struct per muscle), as in the file's /emg
==============  =================================================================

The three groups keep their own time bases (frames, EMG samples) and are exported
whole, also with the exercise's rows only.

Names that are not MATLAB identifiers (a channel of a later instrument, a metric
starting with ``_`` or longer than 63 characters) become one: characters other
than letters, digits and ``_`` become ``_``, a leading non-letter gets an ``x``
before it, and a clash gets ``_2``…; ``channels.name`` keeps the original.
"""

from __future__ import annotations

import datetime
import json
import re
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from app.exports.figures import RECORDED, SOURCE_COLUMN
from app.exports.files import output
from app.exports.trialinfo import Trial
from device.recording.trialfile import software_version

MATLAB_NAME_MAX = 63  # namelengthmax
_NOT_IDENTIFIER = re.compile(r"[^A-Za-z0-9_]")


def matlab_name(name: str, taken: set[str]) -> str:
    """A valid MATLAB identifier for `name`, not in `taken` (which it joins)."""
    text = _NOT_IDENTIFIER.sub("_", name) or "x"
    if not text[0].isalpha():
        text = "x" + text
    text = text[:MATLAB_NAME_MAX]
    candidate, n = text, 2
    while candidate in taken:
        tail = f"_{n}"
        candidate, n = text[:MATLAB_NAME_MAX - len(tail)] + tail, n + 1
    taken.add(candidate)
    return candidate


def mat_variables(trial: Trial, *, exercise_only: bool = False,
                  recorded: Mapping[str, float] | None = None,
                  about: Mapping[str, str] | None = None) -> dict:
    """The variables `write_mat` saves (see the module's doc): `trial.metrics` the figures
    written as ``metrics``, `recorded` the file's own (default: the same), `about` what the
    registry says of the trial (app.exports.run: metrics_source, invalid_reason), fields of
    ``export``."""
    recorded = trial.metrics if recorded is None else recorded
    arrays = trial.arrays
    if exercise_only:
        mask = trial.exercise
        arrays = {name: values[mask] for name, values in arrays.items()}
    taken: set[str] = set()
    fields = {name: matlab_name(name, taken) for name in arrays}
    n_events = len(trial.events)
    return {
        "timeseries": {fields[name]: np.ascontiguousarray(values)
                       for name, values in arrays.items()},
        "channels": {
            "name": _cells(list(arrays)),
            "field": _cells(fields.values()),
            "width": np.array([[1 if v.ndim == 1 else int(np.prod(v.shape[1:]))]
                               for v in arrays.values()], dtype=np.int32).reshape(-1, 1),
            "dtype": _cells(v.dtype.str for v in arrays.values()),
            "units": _cells(trial.units.get(name, "") for name in arrays),
            "frame": _cells(trial.frames.get(name, "") for name in arrays),
            "description": _cells(trial.descriptions.get(name, "") for name in arrays),
        },
        "units": {fields[name]: trial.units.get(name, "") for name in arrays},
        "frames": {fields[name]: trial.frames.get(name, "") for name in arrays},
        "parameters": _struct(trial.parameter_values),
        "metrics": _struct({k: float(v) for k, v in trial.metrics.items()}),
        "metrics_recorded": _struct({k: float(v) for k, v in recorded.items()}),
        "events": {
            "time_s": np.array([e["time_s"] for e in trial.events],
                               dtype=np.float64).reshape(n_events, 1),
            "tick": np.array([e["tick"] for e in trial.events],
                             dtype=np.int64).reshape(n_events, 1),
            "kind": _cells(e["kind"] for e in trial.events),
            "message": _cells(e["message"] for e in trial.events),
            "values": _cells(_json(e["values"]) for e in trial.events),
        },
        "subject": _struct(trial.subject.to_dict() if trial.subject else {}),
        "summary": _struct(trial.summary),
        "attributes": _struct(trial.attributes),
        "export": {
            "source_file": trial.path.name,
            "rows": "exercise" if exercise_only else "all",
            "exported_utc": datetime.datetime.now(datetime.UTC).isoformat(timespec="seconds"),
            "software_version": software_version(),
            **(about or {SOURCE_COLUMN: RECORDED}),
        },
        **{name: _struct(group) for name, group in trial.groups.items()},
    }


def write_mat(trial: Trial, path: Path, *, exercise_only: bool = False,
              overwrite: bool = False, recorded: Mapping[str, float] | None = None,
              about: Mapping[str, str] | None = None) -> Path:
    """Write one trial as a compressed MATLAB v5 file (`recorded`, `about`: as for
    `mat_variables`)."""
    # imported here: scipy.io costs about 0.5 s, which every start of the window and of
    # `rehab` would otherwise pay for an export few of them make
    import scipy.io

    variables = mat_variables(trial, exercise_only=exercise_only, recorded=recorded,
                              about=about)
    with output(path, overwrite=overwrite) as stream:
        scipy.io.savemat(stream, variables, format="5", do_compression=True,
                         long_field_names=True, oned_as="column")
    return path


def _struct(values: Mapping) -> dict:
    taken: set[str] = set()
    return {matlab_name(str(key), taken): _value(value) for key, value in values.items()}


def _value(value):
    """A value savemat stores as MATLAB would expect it."""
    if value is None:
        return np.zeros((0, 0))
    if isinstance(value, bool | np.bool_):
        return np.array(bool(value))
    if isinstance(value, Mapping):
        return _struct(value)
    if isinstance(value, np.ndarray) and value.dtype == object:
        return _cells(value.ravel())  # text columns
    if isinstance(value, list | tuple):
        if all(isinstance(v, int | float) and not isinstance(v, bool) for v in value):
            return np.array(value, dtype=np.float64).reshape(1, -1)
        return _cells(_value(v) for v in value)
    return value


def _cells(values) -> np.ndarray:
    """An N×1 cell array (savemat writes object arrays as cells)."""
    items = list(values)
    cells = np.empty((len(items), 1), dtype=object)
    for i, item in enumerate(items):
        cells[i, 0] = item
    return cells


def _json(values) -> str:
    return json.dumps(values, ensure_ascii=False)
