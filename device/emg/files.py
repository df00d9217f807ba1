"""EMG recordings exported to CSV: the Delsys layouts (device.emg.delsys) and a plain one.

The layout is told from the file's first row:

* `Label: …` lines: an EMGworks export with its channel lines;
* `X[s],…`: an EMGworks export without them;
* `Application:, Trigno Discover (…)`: a Trigno Discover export (1.5–1.7 with or without
  time columns, 2.x; 1.4 is refused: it gives no unit);
* anything else: the plain layout.

Plain CSV: a header row whose first column is the time in seconds (`time`, `time_s`,
`t` or `time [s]`), then one column per channel, optionally with its unit in brackets
(`biceps [mV]`; volts when none); `#` lines are comments. The rate is the mean step;
the samples must be evenly spaced (core.signal.sample_interval refuses gaps).

Any of them may be separated by `;` with decimal commas (device.emg.emgtext). Every
malformed file raises EmgFileError: one line naming the file, the layout recognised, the
line and what is wrong.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np

from core.emg.units import volts_per_unit
from core.errors import ParameterError
from core.signal import sample_interval
from device.emg import delsys
from device.emg.emgtext import EmgData, EmgFileError, Text, check_range, read_text
from device.safewrite import write_text

__all__ = ["EmgData", "EmgFileError", "read_emg_file", "read_plain_csv", "read_trigno_csv",
           "write_plain_csv", "write_trigno_csv"]

TIME_NAMES = ("time", "time_s", "t", "time [s]", "time[s]", "x[s]")
PLAIN = "a plain CSV (no Delsys header recognised)"
_UNIT_IN_NAME = re.compile(r"^(?P<name>.*?)\s*\[(?P<unit>[^\]]+)\]\s*$")


def read_emg_file(path: str | os.PathLike) -> EmgData:
    """EMG from an exported file, in the layout its first row shows (above)."""
    text = read_text(Path(path))
    first = next(line for line in text.lines if line.strip())
    if delsys.is_emgworks_labels(first):
        return delsys.read_emgworks_labels(text)
    rows = text.rows(0)
    if not rows:
        raise EmgFileError(text.path, "has only comments", "export the recording again")
    header = rows[0][1]
    if delsys.is_discover(header):
        return delsys.read_discover(text)
    if delsys.is_emgworks_plain(header):
        return delsys.read_emgworks_plain(text)
    return _plain(text, rows)


def read_trigno_csv(path: str | os.PathLike) -> EmgData:
    return delsys.read_emgworks_labels(read_text(Path(path)))


def read_plain_csv(path: str | os.PathLike) -> EmgData:
    text = read_text(Path(path))
    rows = text.rows(0)
    if not rows:
        raise EmgFileError(text.path, "has only comments", "export the recording again")
    return _plain(text, rows)


# ------------------------------------------------------------------ reading
def _plain(text: Text, rows) -> EmgData:
    path = text.path
    header_line, header = rows[0]
    if header[0].lower() not in TIME_NAMES:
        raise EmgFileError(path, f"{PLAIN}: line {header_line}: the first column is "
                                 f"{header[0]!r}, not the time",
                           "name it 'time' (seconds), as docs/data-format.md shows, or give "
                           "the Delsys export as the software wrote it")
    if len(header) < 2:
        raise EmgFileError(path, f"{PLAIN}: no EMG column after the time")
    names, scales, said = [], [], []
    for column in header[1:]:
        match = _UNIT_IN_NAME.match(column)
        name, unit = (match["name"].strip(), match["unit"]) if match else (column, "V")
        said.append(f"in {unit.strip()} as its name says" if match
                    else "no unit in its name, so volts were taken")
        scale = volts_per_unit(unit)
        if not name:
            raise EmgFileError(path, f"{PLAIN}: line {header_line}: a column has no name")
        if scale is None:
            raise EmgFileError(path, f"{PLAIN}: line {header_line}: column {name!r} is in "
                                     f"{unit!r}, not a voltage", "give the unit as V, mV or uV")
        names.append(name)
        scales.append(scale)
    if len(set(names)) != len(names):
        raise EmgFileError(path, f"{PLAIN}: line {header_line}: two columns share one name")
    data = []
    for line, row in rows[1:]:
        if len(row) != len(header):
            raise EmgFileError(path, f"{PLAIN}: line {line}: {len(row)} cells, the header has "
                                     f"{len(header)}")
        data.append([text.number(line, header[c], cell, f"{PLAIN}: ")
                     for c, cell in enumerate(row)])
    if len(data) < 2:
        raise EmgFileError(path, f"{PLAIN}: {len(data)} samples", "a recording needs at least two")
    array = np.array(data)
    t = array[:, 0]
    try:
        sample_interval(t)  # one-dimensional, finite, increasing, no gaps
    except ParameterError as exc:
        raise EmgFileError(path, f"{PLAIN}: the time column: {exc}") from None
    # the mean rate: time stamps printed with few decimals make the median step inexact
    rate = (t.size - 1) / (t[-1] - t[0])
    volts = array[:, 1:] * np.array(scales)
    for c, name in enumerate(names):
        check_range(path, PLAIN, name, volts[:, c], said[c])
    return EmgData(tuple(names), float(rate), t, volts, "csv", path, text.notes)


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
