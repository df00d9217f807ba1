"""EMG recordings exported to CSV: the Delsys Trigno (EMGworks) layout and a plain one.

Delsys Trigno CSV export (one file, comma separated):

    Label: EMG1 Sampling frequency: 1925.926 Unit: V Domain: Time
    Label: EMG2 Sampling frequency: 1925.926 Unit: V Domain: Time
    Label: ACC1.X Sampling frequency: 148.148 Unit: g Domain: Time
                                                   (blank lines may follow)
    X[s],EMG1,X[s],EMG2,X[s],ACC1.X
    0.000000,1.2e-05,0.000000,-3.1e-06,0.000000,0.01
    0.000519,...                                   (a slower channel's cells end early)

One `Label:` line per channel (EMGworks may add `Number of points: N` and `start: s`
before `Unit:`), then a header with a time column `X[s]` before each channel's values.
Channels whose unit is a voltage (V, mV, uV/µV, Volts) are the EMG, converted to volts;
the others (accelerometers in g, …) are skipped and named in the notes. The EMG channels
must share one rate and one time column.

Plain CSV: a header row whose first column is the time in seconds (`time`, `time_s`,
`t` or `time [s]`), then one column per channel, optionally with its unit in brackets
(`biceps [mV]`; volts when none); `#` lines are comments. The rate is the median step;
the samples must be evenly spaced (core.signal.sample_interval refuses gaps).

Every malformed file raises EmgFileError: one line naming the file, the line and what
is wrong.
"""

from __future__ import annotations

import csv
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.emg.units import volts_per_unit
from core.errors import ParameterError
from core.signal import sample_interval
from device.errors import DeviceError
from device.safeinput import InputRefused, read_bytes
from device.safewrite import write_text

TIME_NAMES = ("time", "time_s", "t", "time [s]", "time[s]", "x[s]")
MAX_BYTES = 2 * 2**30  # a 2 GiB CSV is a mistake, not an EMG recording of a session
_LABEL = re.compile(
    r"^\s*Label:\s*(?P<label>.+?)\s+Sampling frequency:\s*(?P<fs>\S+)"
    r"(?:\s+Number of points:\s*\S+)?(?:\s+start:\s*\S+)?"
    r"\s+Unit:\s*(?P<unit>.+?)\s+Domain:\s*(?P<domain>\S+)\s*$")
_UNIT_IN_NAME = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\]]+)\]\s*$")


class EmgFileError(DeviceError):
    """An EMG file cannot be read; the message is the one line shown."""

    def __init__(self, path: object, problem: str, advice: str = "") -> None:
        self.path, self.problem = path, problem
        text = f"EMG file {path}: {problem}"
        super().__init__(f"{text}. {advice[:1].upper()}{advice[1:]}" if advice else text)


@dataclass(frozen=True, slots=True, eq=False)
class EmgData:
    """EMG read from a file: `samples` (M, C) in volts at `t_s` (M,), the file's own
    clock in seconds, `rate_hz`, one name per channel, `source` (`trigno-csv` or
    `csv`), and notes on what was skipped."""

    names: tuple[str, ...]
    rate_hz: float
    t_s: np.ndarray
    samples: np.ndarray
    source: str
    path: Path
    notes: tuple[str, ...] = ()


def read_emg_file(path: str | os.PathLike) -> EmgData:
    """A Trigno export when the file starts with `Label:` lines, else a plain CSV."""
    path = Path(path)
    lines = _lines(path)
    first = next((line for line in lines if line.strip()), "")
    if first.lstrip().startswith("Label:"):
        return _trigno(path, lines)
    return _plain(path, lines)


def read_trigno_csv(path: str | os.PathLike) -> EmgData:
    path = Path(path)
    return _trigno(path, _lines(path))


def read_plain_csv(path: str | os.PathLike) -> EmgData:
    path = Path(path)
    return _plain(path, _lines(path))


# ------------------------------------------------------------------ reading
def _lines(path: Path) -> list[str]:
    try:
        if not path.exists():
            raise EmgFileError(path, "no such file", "check the path")
        if path.is_dir():
            raise EmgFileError(path, "is a folder, not a file", "give the exported .csv file")
        # a plain file of a bounded size, read without blocking (device.safeinput): a pipe
        # would hang the reader, /dev/zero fill the memory
        text = read_bytes(path, what="EMG file", max_bytes=MAX_BYTES).decode("utf-8-sig")
    except InputRefused as exc:
        raise EmgFileError(path, exc.problem, "give the exported .csv file") from None
    except UnicodeDecodeError:
        raise EmgFileError(path, "is not a text file (not UTF-8)",
                           "export the recording as CSV from the EMG software") from None
    except OSError as exc:
        raise EmgFileError(path, f"cannot be read ({exc.strerror or exc})") from None
    lines = text.splitlines()
    if not any(line.strip() for line in lines):
        raise EmgFileError(path, "is empty", "export the recording again")
    return lines


def _rows(path: Path, lines: list[str], start: int) -> list[tuple[int, list[str]]]:
    out = []
    k = start
    try:
        for k, row in enumerate(csv.reader(lines[start:]), start=start + 1):
            if not row or all(not c.strip() for c in row) or row[0].lstrip().startswith("#"):
                continue
            out.append((k, row))
    except csv.Error as exc:  # a cell over the csv module's limit (131,072 characters), …
        raise EmgFileError(path, f"line {k + 1} cannot be read as CSV ({exc})",
                           "the file may not be an EMG export") from None
    return out


def _number(path: Path, line: int, column: str, cell: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise EmgFileError(path, f"line {line}, column {column!r}: {cell.strip()!r} is not a "
                                 "number", "the file may be cut or edited by hand") from None
    if not math.isfinite(value):
        raise EmgFileError(path, f"line {line}, column {column!r}: {cell.strip()} is not finite")
    return value


def _trigno(path: Path, lines: list[str]) -> EmgData:
    labels = []
    k = 0
    while k < len(lines) and (not lines[k].strip() or lines[k].lstrip().startswith("Label:")):
        line = lines[k]
        k += 1
        if not line.strip():
            continue
        match = _LABEL.match(line)
        if not match:
            raise EmgFileError(path, f"line {k}: not a Trigno channel line "
                                     "('Label: … Sampling frequency: … Unit: … Domain: …')")
        try:
            fs = float(match["fs"])
        except ValueError:
            fs = math.nan
        if not (math.isfinite(fs) and fs > 0):
            raise EmgFileError(path, f"line {k}: sampling frequency {match['fs']!r} of "
                                     f"{match['label']} is not a rate in Hz")
        labels.append((match["label"].strip(), fs, match["unit"].strip()))
    if not labels:
        raise EmgFileError(path, "no 'Label:' lines", "this is not a Trigno CSV export")
    rows = _rows(path, lines, k)
    if not rows:
        raise EmgFileError(path, "no header row after the 'Label:' lines",
                           "the export is cut; export it again")
    header_line, header = rows[0]
    header = [h.strip() for h in header]
    while header and not header[-1]:
        header.pop()
    if len(header) != 2 * len(labels):
        raise EmgFileError(path, f"line {header_line}: the header has {len(header)} columns, "
                                 f"expected {2 * len(labels)} (a time column X[s] and a value "
                                 f"column for each of the {len(labels)} channels)")
    for j, (label, _, _) in enumerate(labels):
        if header[2 * j].lower() != "x[s]":
            raise EmgFileError(path, f"line {header_line}: column {2 * j + 1} is "
                                     f"{header[2 * j]!r}, expected the time column 'X[s]' of "
                                     f"{label}")
    emg = [j for j, (_, _, unit) in enumerate(labels) if volts_per_unit(unit) is not None]
    skipped = [f"{label} ({unit})" for j, (label, _, unit) in enumerate(labels) if j not in emg]
    if not emg:
        raise EmgFileError(path, "no EMG channel: no channel is in volts",
                           "export the EMG channels (unit V) too")
    rates = {labels[j][1] for j in emg}
    if len(rates) > 1:
        listed = ", ".join(f"{labels[j][0]} {labels[j][1]:g} Hz" for j in emg)
        raise EmgFileError(path, f"the EMG channels have different rates ({listed})",
                           "export them at one rate")
    names = [labels[j][0] for j in emg]
    if len(set(names)) != len(names):
        raise EmgFileError(path, "two EMG channels share one label", "rename one in the export")
    if len(rows) < 2:
        raise EmgFileError(path, "no samples after the header",
                           "the export is cut or empty; export it again")
    t = []
    values = []
    for line, row in rows[1:]:
        cells = [c.strip() for c in row]
        first = cells[2 * emg[0]] if 2 * emg[0] < len(cells) else ""
        if not first:
            break  # the EMG channels have ended; slower channels may end first, not these
        for j in emg:
            if 2 * j + 1 >= len(cells) or not cells[2 * j] or not cells[2 * j + 1]:
                raise EmgFileError(path, f"line {line}: {labels[j][0]} has no sample where "
                                         f"{labels[emg[0]][0]} has one",
                                   "the EMG channels must have the same samples")
        t.append(_number(path, line, "X[s]", first))
        values.append([_number(path, line, labels[j][0], cells[2 * j + 1]) for j in emg])
        for j in emg[1:]:
            other = _number(path, line, "X[s]", cells[2 * j])
            if abs(other - t[-1]) > 0.5 / labels[j][1]:
                raise EmgFileError(path, f"line {line}: the time of {labels[j][0]} ({other:g} s) "
                                         f"differs from that of {labels[emg[0]][0]} "
                                         f"({t[-1]:g} s)", "the EMG channels must share a clock")
    scale = np.array([volts_per_unit(labels[j][2]) for j in emg])
    notes = (f"skipped channels that are not EMG: {', '.join(skipped)}",) if skipped else ()
    return _finish(path, names, np.array(t), np.array(values) * scale, "trigno-csv",
                   labels[emg[0]][1], notes)


def _plain(path: Path, lines: list[str]) -> EmgData:
    rows = _rows(path, lines, 0)
    if not rows:
        raise EmgFileError(path, "has only comments", "export the recording again")
    header_line, header = rows[0]
    header = [h.strip() for h in header]
    if header[0].lower() not in TIME_NAMES:
        raise EmgFileError(path, f"line {header_line}: the first column is {header[0]!r}, not "
                                 "the time", "name it 'time' (seconds), as docs/data-format.md "
                                 "shows, or export the Trigno layout")
    if len(header) < 2:
        raise EmgFileError(path, "no EMG column after the time")
    names, scales = [], []
    for column in header[1:]:
        match = _UNIT_IN_NAME.match(column)
        name, unit = (match["name"].strip(), match["unit"]) if match else (column, "V")
        scale = volts_per_unit(unit)
        if not name:
            raise EmgFileError(path, f"line {header_line}: a column has no name")
        if scale is None:
            raise EmgFileError(path, f"line {header_line}: column {name!r} is in {unit!r}, "
                                     "not a voltage", "give the unit as V, mV or uV")
        names.append(name)
        scales.append(scale)
    if len(set(names)) != len(names):
        raise EmgFileError(path, f"line {header_line}: two columns share one name")
    data = []
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise EmgFileError(path, f"line {line}: {len(row)} cells, the header has "
                                     f"{len(header)}")
        data.append([_number(path, line, header[c], cell) for c, cell in enumerate(row)])
    if len(data) < 2:
        raise EmgFileError(path, f"{len(data)} samples", "a recording needs at least two")
    array = np.array(data)
    t = array[:, 0]
    try:
        sample_interval(t)  # one-dimensional, finite, increasing, no gaps
    except ParameterError as exc:
        raise EmgFileError(path, f"the time column: {exc}") from None
    # the mean rate: time stamps printed with few decimals make the median step inexact
    rate = (t.size - 1) / (t[-1] - t[0])
    return _finish(path, names, t, array[:, 1:] * np.array(scales), "csv", rate, ())


def _finish(path, names, t, samples, source, rate_hz, notes) -> EmgData:
    if t.size < 2:
        raise EmgFileError(path, f"{t.size} samples", "a recording needs at least two")
    step = np.diff(t)
    if (step <= 0).any():
        k = int(np.flatnonzero(step <= 0)[0]) + 1
        raise EmgFileError(path, f"the time goes back or stands still at sample {k} "
                                 f"({t[k]:g} s)", "the file may be two recordings joined")
    return EmgData(tuple(names), float(rate_hz), t, samples.reshape(t.size, len(names)), source,
                   path, notes)


# ------------------------------------------------------------------ writing (sample files, tests)
def write_trigno_csv(path: str | os.PathLike, names, rate_hz: float, samples,
                     extra: tuple = (), *, overwrite: bool = False) -> Path:
    """Write EMG (M, C) in V in the Trigno export layout; `extra` adds non-EMG channels as
    (label, rate_hz, unit, values) so files look like real exports. Whole or not at all,
    never over a file unless `overwrite` (device.safewrite)."""
    path = Path(path)
    samples = np.asarray(samples, dtype=float)
    channels = [(n, rate_hz, "V", samples[:, i]) for i, n in enumerate(names)] + list(extra)
    lines = [f"Label: {n} Sampling frequency: {fs:.10g} Unit: {u} Domain: Time"
             for n, fs, u, _ in channels]
    lines.append("")
    lines.append(",".join(f"X[s],{n}" for n, _, _, _ in channels))
    longest = max(len(v) for *_, v in channels)
    for k in range(longest):
        cells = []
        for _, fs, _, v in channels:
            cells += [f"{k / fs:.6f}", f"{v[k]:.9g}"] if k < len(v) else ["", ""]
        lines.append(",".join(cells))
    return write_text(path, "\n".join(lines) + "\n", overwrite=overwrite)


def write_plain_csv(path: str | os.PathLike, names, t_s, samples, *,
                    overwrite: bool = False) -> Path:
    """Write EMG (M, C) in V as the plain layout: `time` then one column per channel; whole
    or not at all, never over a file unless `overwrite` (device.safewrite)."""
    path = Path(path)
    samples = np.asarray(samples, dtype=float)
    lines = ["time," + ",".join(f"{n} [V]" for n in names)]
    lines += [f"{t:.6f}," + ",".join(f"{v:.9g}" for v in row) for t, row in zip(t_s, samples,
                                                                              strict=True)]
    return write_text(path, "\n".join(lines) + "\n", overwrite=overwrite)
