"""CSV and TSV export of one trial: a samples file and four small side files.

For a stem S (`.csv` with commas, `.tsv` with tabs; UTF-8, ``\\n`` line ends):

==================  ===============================================================
``S.csv``           one row per sample, one column per channel component, named as
                    in app.exports.columns (``position_x_m``…, each name ending in its
                    unit). **One header line**, the names; the exact unit text of each
                    column is in ``S_columns.csv``. Numbers read back exactly by
                    default (see app.exports.columns for `digits`); NaN is ``NaN``.
``S_columns.csv``   column, channel, component, units, frame, description
``S_events.csv``    time_s, tick, kind, message, values (the event's JSON object)
``S_metrics.csv``   metric, value, recorded (names carry their units; NaN = undefined):
                    `value` the figure the registry stands by, `recorded` the trial
                    file's own; they differ only after `rehab reanalyse` re-computed it
                    (app.exports.figures)
``S_emg.csv``       when the trial has EMG: time_s (trial time) and one column per muscle
                    in volts (``biceps_V``), at the EMG's own rate
``S_trial.csv``     key, value: status, sample period, subject code and
                    anthropometry, every parameter (the row keys of app.exports.loader),
                    which samples the samples file holds (``rows``: all/exercise),
                    whose figures the metrics file's values are (``metrics_source``:
                    recorded/registry) and why the registry marks the trial invalid
                    (``invalid_reason``, '' when it does not)
==================  ===============================================================

One header line and numbers only below it, so every reader takes the file as it is, with
no options: ``pandas.read_csv(path)`` (float64 columns, int64 for ticks, codes and
flags), ``numpy.genfromtxt(path, delimiter=",", names=True)``, MATLAB's
``readtable(path)``, R's ``read.csv(path)``, a spreadsheet. An earlier version wrote the
units as a second header line: pandas then read every column as text and numpy's
``names=True`` took the units line for a sample. The units are the side file's
(``S_columns.csv``: column, units, frame, description), and the column names end in them.
"""

from __future__ import annotations

import csv
import json
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TextIO

import numpy as np

from app.exports.columns import (
    Column,
    check_digits,
    column_values,
    format_values,
    table_columns,
)
from app.exports.figures import RECORDED, SOURCE_COLUMN
from app.exports.files import output
from app.exports.trialinfo import Trial
from device.recording.emgfile import read_emg

CHUNK_ROWS = 4096  # keeps memory flat: the text of one chunk at a time
SIDE_FILES = ("columns", "events", "metrics", "trial", "emg")
DELIMITERS = {".csv": ",", ".tsv": "\t"}


def table_outputs(folder: Path, stem: str, suffix: str) -> tuple[Path, ...]:
    """The files `write_table` may write for this stem, samples file first (the EMG file
    only when the trial has EMG)."""
    return (folder / f"{stem}{suffix}",
            *(folder / f"{stem}_{side}{suffix}" for side in SIDE_FILES))


def write_table(trial: Trial, folder: Path, stem: str, *, suffix: str = ".csv",
                exercise_only: bool = False, digits: int | None = None,
                overwrite: bool = False, recorded: Mapping[str, float] | None = None,
                about: Mapping[str, str] | None = None) -> tuple[Path, ...]:
    """Write the samples file and its side files; returns their paths. `trial.metrics`
    are the figures written as `value`; `recorded` the file's own (default: the same);
    `about` what the registry says of the trial (app.exports.run: metrics_source,
    invalid_reason), keys of the `_trial` table."""
    digits = check_digits(digits)
    recorded = trial.metrics if recorded is None else recorded
    delimiter = DELIMITERS[suffix]
    samples, columns_file, events_file, metrics_file, trial_file, emg_file = table_outputs(
        folder, stem, suffix)
    arrays = trial.arrays
    if exercise_only:
        mask = trial.exercise
        arrays = {name: values[mask] for name, values in arrays.items()}
    columns = table_columns(arrays, trial.units, trial.frames, trial.descriptions)
    n = next(iter(arrays.values())).shape[0] if arrays else 0

    with output(samples, overwrite=overwrite, text=True) as stream:
        header = csv.writer(stream, delimiter=delimiter, lineterminator="\n")
        header.writerow([c.name for c in columns])
        write_samples(stream, arrays, columns, delimiter, digits=digits)

    _write_rows(columns_file, delimiter, overwrite,
                ("column", "channel", "component", "units", "frame", "description"),
                [(c.name, c.channel, c.component, c.units, c.frame, c.description)
                 for c in columns])
    _write_rows(events_file, delimiter, overwrite,
                ("time_s", "tick", "kind", "message", "values"),
                [(_number(e["time_s"], digits), e["tick"], e["kind"], e["message"],
                  json.dumps(e["values"], ensure_ascii=False)) for e in trial.events])
    _write_rows(metrics_file, delimiter, overwrite, ("metric", "value", "recorded"),
                [(name, _number(value, digits), _number(recorded.get(name, math.nan), digits))
                 for name, value in trial.metrics.items()])
    info = {key: value for key, value in trial.row().items() if not key.startswith("metric_")}
    info |= about or {SOURCE_COLUMN: RECORDED}
    info |= {"rows": "exercise" if exercise_only else "all", "rows_written": n,
             "notes": " | ".join(trial.notes)}
    _write_rows(trial_file, delimiter, overwrite, ("key", "value"),
                [(key, _text(value, digits)) for key, value in info.items()])
    written = (samples, columns_file, events_file, metrics_file, trial_file)
    emg = read_emg(trial.path)
    if emg is None:
        return written
    keep = np.ones(emg.time_s.shape, dtype=bool)
    if exercise_only and n:
        keep = (emg.time_s >= arrays["time"][0]) & (emg.time_s <= arrays["time"][-1])
    texts = [format_values(emg.time_s[keep], digits=digits)] + [
        format_values(emg.samples[keep, k], digits=digits) for k in range(len(emg.muscles))]
    with output(emg_file, overwrite=overwrite, text=True) as stream:
        header = csv.writer(stream, delimiter=delimiter, lineterminator="\n")
        header.writerow(["time_s", *(f"{muscle}_V" for muscle in emg.muscles)])
        if texts[0]:
            stream.write("\n".join(map(delimiter.join, zip(*texts, strict=True))) + "\n")
    return (*written, emg_file)


def write_samples(stream: TextIO, arrays: Mapping[str, np.ndarray], columns: Sequence[Column],
                  delimiter: str, *, digits: int | None = None, missing: str = "NaN") -> None:
    """One line per sample, the columns' values separated by `delimiter`."""
    n = next(iter(arrays.values())).shape[0] if arrays else 0
    for start in range(0, n, CHUNK_ROWS):
        stop = min(start + CHUNK_ROWS, n)
        texts = [format_values(column_values(arrays, c)[start:stop], digits=digits,
                               missing=missing) for c in columns]
        stream.write("\n".join(map(delimiter.join, zip(*texts, strict=True))))
        stream.write("\n")


def _write_rows(path: Path, delimiter: str, overwrite: bool, header: tuple, rows: list) -> None:
    with output(path, overwrite=overwrite, text=True) as stream:
        writer = csv.writer(stream, delimiter=delimiter, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)


def _number(value: float, digits: int | None) -> str:
    return format_values(np.array([value], dtype=np.float64), digits=digits)[0]


def _text(value, digits: int | None) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return _number(value, digits)
    if isinstance(value, bool):
        return "true" if value else "false"
    return str(value)
