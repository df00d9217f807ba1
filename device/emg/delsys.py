"""Delsys CSV exports: every layout found described in public sources, never guessed.

EMG is kept, in volts (core.emg.units.volts_per_unit, the unit the file gives); the other
channels (ACC, GYRO, IMU, Analog, EKG, FSR, link devices) are skipped and named in one
note; EMG channels at different rates are brought to the fastest EMG rate
(device.emg.channels). Every refusal names the layout recognised.

1. EMGworks with `Label:` lines (source: bensenderling/DAMVi_App Load/load_csv_Delsys.m,
   which reads "while strcmp(line(1:5),'Label')" the channel lines, then the `X[s]`
   header; our tests/data/emg/trigno_export.csv)::

       Label: EMG1 Sampling frequency: 1925.926 Unit: V Domain: Time
       Label: ACC1.X Sampling frequency: 148.148 Unit: g Domain: Time
       X[s],EMG1,X[s],ACC1.X
       0.000000,1.2e-05,0.000000,0.01            (a slower channel's cells end early)

   EMGworks may add `Number of points: N` and `start: s` before `Unit:`. The unit is the
   `Unit:` of each channel. As EMGworks really writes them (source: neuromechanist/emgio
   examples/truncated_trigno_sample.csv, a truncated real export of Trigno Mini sensors)::

       Label: Mini sensor 10: EMG 10 Sampling frequency: 1.259259e+003 Number of points:
              81141 start: 0.000000e+000 Unit: V Domain Unit: s          (one line)
       Label: Mini sensor 10: GYRO.X 10 Sampling frequency: 1.481481e+002 … Unit: °/s …
       Start Trigger Method: None
       Stop Trigger Method: None

       X[s],"Mini sensor 10: EMG 10",X[s],"Mini sensor 10: ACC.X 10",…

   the line ends `Domain Unit: s`, and `Name: value` lines (the triggers) may stand
   between the channel lines and the header; a lab's export may say `Unit: Volts`.

2. EMGworks without `Label:` lines (source: praneethnamburi/delsys, PyPI `delsys`,
   tests/fixtures/emgworks.csv, a trimmed real export)::

       X[s],"Avanti sensor 1: EMG 1",X[s],"Avanti sensor 1: ACC.X 1",…
       0.0005192308,-7.150377E-05,0.00675,0.4316406,…

   The file names no unit; EMGworks writes EMG in volts (the `Unit: V` of its `Label:`
   lines; the real export's EMG cells are 1e-6–1e-4, surface EMG in volts), so volts are
   taken and a note says so. A channel is EMG when its name after `: ` starts with `EMG`.
   The rate of each channel is its time column's (mean step).

3. Trigno Discover 1.5–1.7, "basic" (no time columns) (source: praneethnamburi/delsys
   tests/fixtures/discover150.csv, discover164_basic.csv, discover170.csv, trimmed real
   exports of Discover 1.5.0, 1.6.4, 1.7.0, and its src/delsys/_parse.py)::

       Application:, Trigno Discover (1.7.0)
       Date/Time:, 4/10/2026 12:13:39 PM
       Collection Length (seconds):, 0.090000
       EMG 01 03558 (88016), , , , , , , Quattro 19 01639 (79082), , , ,     (sensors)
       sensor mode: 55, , , , , , , sensor mode: 296, , , ,                  (modes)
       EMG 1 (mV), ACC X (G), …, EMG 1 (mV), EMG 2 (mV), EMG 3 (mV), EMG 4 (mV)
       1259.2593 Hz, 148.1481 Hz, …, 2222.2222 Hz, 2222.2222 Hz, …           (rates)
       0.0018463, 0.0250244, …

   Each column holds its channel's samples from the first data row at the channel's own
   rate (t = k / rate); the file has round(length × fastest rate) rows, and a channel at
   rate f has round(length × f) samples — cells beyond those (a slower channel's column
   runs out) are ignored, and said so.

4. Trigno Discover 1.6 with "Time Series" columns (source: praneethnamburi/delsys
   tests/fixtures/discover164_link.csv, a trimmed real Discover 1.6.4 export): as 3, but
   each channel `EMG 1 (mV)` follows its own time column `EMG 1 Time Series (s)`, and the
   rate row is blank under the time columns (`, 1925.9259 Hz, , 74.0741 Hz`).

5. Trigno Discover 2.x (source: three public readers of Discover 2.1.0.7 exports on
   GitHub: an `emg_pipeline/delsys_parser.py` ("Eight header rows precede the data … row 8:
   sample period (", 0.000794 s, , 0.00675 s")", slower channels "leaving empty cells",
   "annotation/event columns may be appended on the right"), a converter "confirmed on
   Trigno Discover 2.1.0.7" (row 8 the sample interval and, to its right, the marker
   table's heading `Type, Name, Label, Time (s)`), and its test writer): as 4 with an
   eighth header row of sample periods. Columns right of the channel names (markers) are
   ignored.

Trigno Discover 1.4.2 (source: praneethnamburi/delsys tests/fixtures/discover142.csv) has
six header rows and its channel names carry the rate instead of the unit (`EMG 1
(1259Hz)`): the file does not say its unit, so it is refused (re-export it with Discover
1.5 or later, or as EMGworks).
"""

from __future__ import annotations

import re
from collections import Counter

import numpy as np

from core.emg.units import volts_per_unit
from core.errors import ParameterError
from core.signal import sample_interval
from device.emg.channels import Channel, combine, printed_grid, trigno_rate
from device.emg.emgtext import EmgData, EmgFileError, Text

_LABEL = re.compile(
    r"^\s*Label:\s*(?P<label>.+?)\s+Sampling frequency:\s*(?P<fs>\S+)"
    r"(?:\s+Number of points:\s*\S+)?(?:\s+start:\s*\S+)?"
    r"\s+Unit:\s*(?P<unit>.+?)\s+Domain(?: Unit)?:\s*(?P<domain>\S+)\s*$")
_SETTING = re.compile(r"^\s*[A-Za-z][A-Za-z ]*:\s*[^,;]*$")  # 'Stop Trigger Method: None'
_VERSION = re.compile(r"Trigno Discover\s*\(\s*(?P<version>[^)]*?)\s*\)")
_UNIT = re.compile(r"^(?P<name>.*?)\s*\((?P<unit>[^()]*)\)$")
_RATE = re.compile(r"^(?P<rate>[0-9.,]+)\s*Hz$")
_PERIOD = re.compile(r"^[0-9.,eE+-]+\s*s$")
_RATE_IN_NAME = re.compile(r"\(\s*[0-9.,]+\s*Hz\s*\)$")
TIME_SERIES = " Time Series (s)"
MAX_LENGTH_S = 7 * 24 * 3600.0  # a week: longer is a damaged header, not a collection
EMGWORKS_LABELS = "an EMGworks export with 'Label:' lines"
EMGWORKS_PLAIN = "an EMGworks export without 'Label:' lines"


def is_emgworks_labels(first: str) -> bool:
    return first.lstrip().startswith("Label:")


def is_emgworks_plain(header: list[str]) -> bool:
    """`X[s]` then a channel named `sensor: channel`, or more than one `X[s]` column."""
    if len(header) < 2 or header[0].lower() != "x[s]":
        return False
    return ":" in header[1] or sum(h.lower() == "x[s]" for h in header) > 1


def is_discover(header: list[str]) -> bool:
    return bool(header) and header[0].rstrip(":").strip().lower() == "application"


# ------------------------------------------------------------------ EMGworks
def read_emgworks_labels(text: Text) -> EmgData:
    layout = EMGWORKS_LABELS
    labels = []
    lines = text.lines
    k = 0
    while k < len(lines) and (not lines[k].strip() or is_emgworks_labels(lines[k])):
        line = lines[k]
        k += 1
        if not line.strip():
            continue
        match = _LABEL.match(line)
        if not match:
            raise EmgFileError(text.path, f"{layout}: line {k}: not a Trigno channel line "
                                          "('Label: … Sampling frequency: … Unit: … Domain: …')")
        fs = _rate(match["fs"].replace(",", ".") if text.decimal_comma else match["fs"])
        if fs is None:
            raise EmgFileError(text.path, f"{layout}: line {k}: sampling frequency "
                                          f"{match['fs']!r} of {match['label']} is not a rate "
                                          "in Hz")
        labels.append((match["label"].strip(), fs, match["unit"].strip()))
    rows = text.rows(k)
    while rows and rows[0][1][0].lower() != "x[s]" and _SETTING.match(text.lines[rows[0][0] - 1]):
        rows = rows[1:]  # 'Start Trigger Method: None', … between the channels and the header
    if not rows:
        raise EmgFileError(text.path, f"{layout}: no header row after the 'Label:' lines",
                           "the export is cut; export it again")
    header_line, header = rows[0]
    while header and not header[-1]:
        header.pop()
    if len(header) != 2 * len(labels):
        raise EmgFileError(text.path, f"{layout}: line {header_line}: the header has "
                                      f"{len(header)} columns, expected {2 * len(labels)} (a "
                                      "time column X[s] and a value column for each of the "
                                      f"{len(labels)} channels)",
                           "export it again from EMGworks with a time column for each "
                           "channel")
    for j, (label, _, _) in enumerate(labels):
        if header[2 * j].lower() != "x[s]":
            raise EmgFileError(text.path, f"{layout}: line {header_line}: column {2 * j + 1} "
                                          f"is {header[2 * j]!r}, expected the time column "
                                          f"'X[s]' of {label}")
    if len(rows) < 2:
        raise EmgFileError(text.path, f"{layout}: no samples after the header",
                           "the export is cut or empty; export it again")
    channels, skipped = [], Counter()
    for j, (label, fs, unit) in enumerate(labels):
        scale = volts_per_unit(unit)
        if scale is None:
            skipped[f"{label} ({unit})"] += 1
            continue
        t, v, at = _pairs(text, layout, rows[1:], 2 * j, 2 * j + 1, label)
        channels.append(Channel(label, fs, float(t[0]) if t.size else 0.0, v * scale, at, t,
                                unit))
    return combine(text, layout, "trigno-csv", channels, _listed(skipped))


def read_emgworks_plain(text: Text) -> EmgData:
    layout = EMGWORKS_PLAIN
    rows = text.rows(0)
    header_line, header = rows[0]
    while header and not header[-1]:
        header.pop()
    if len(header) % 2:
        raise EmgFileError(text.path, f"{layout}: line {header_line}: {len(header)} columns, "
                                      "expected pairs of a time column X[s] and a channel")
    if len(rows) < 2:
        raise EmgFileError(text.path, f"{layout}: no samples after the header",
                           "the export is cut or empty; export it again")
    channels, skipped = [], Counter()
    for j in range(0, len(header), 2):
        name = header[j + 1]
        if header[j].lower() != "x[s]":
            raise EmgFileError(text.path, f"{layout}: line {header_line}: column {j + 1} is "
                                          f"{header[j]!r}, expected the time column 'X[s]' of "
                                          f"{name}")
        if not name.rpartition(": ")[2].upper().startswith("EMG"):
            skipped[name.rpartition(": ")[2] or name] += 1
            continue
        t, v, at = _pairs(text, layout, rows[1:], j, j + 1, name)
        if t.size < 2:
            raise EmgFileError(text.path, f"{layout}: {t.size} samples of {name}",
                               "a recording needs at least two; export it again")
        rate = (t.size - 1) / (t[-1] - t[0]) if t[-1] > t[0] else 0.0  # the mean:
        # printed stamps round each step; from 1000 s on they stand still between samples,
        # and the rate is the Trigno rate whose grid they are
        on_grid = [r for r in (rate, trigno_rate(rate)) if printed_grid(t, r) is not None]
        if on_grid:
            rate = on_grid[0]
        else:
            try:
                sample_interval(t)  # finite, increasing, no gaps
            except ParameterError as exc:
                raise EmgFileError(text.path, f"{layout}: the time column of {name}: "
                                              f"{exc}") from None
        channels.append(Channel(name, float(rate), float(t[0]), v, at, t))
    note = ("units: the export names none; EMGworks writes EMG in volts (its 'Label:' "
            "lines say Unit: V), so volts were taken")
    return combine(text, layout, "emgworks-csv", channels, _listed(skipped), [note])


# ------------------------------------------------------------------ Trigno Discover
def read_discover(text: Text) -> EmgData:
    rows = text.rows(0)
    version_match = _VERSION.search(" ".join(rows[0][1][1:]))
    version = version_match["version"] if version_match else "(version not given)"
    layout = f"a Trigno Discover {version} export"
    if len(rows) < 7:
        raise EmgFileError(text.path, f"{layout}: {len(rows)} lines, fewer than its header "
                                      "(application, date, length, sensors, modes, channels, "
                                      "rates)", "the export is cut; export it again")
    length_line, length_row = rows[2]
    if not length_row[0].lower().startswith("collection length") or len(length_row) < 2:
        raise EmgFileError(text.path, f"{layout}: line {length_line} is "
                                      f"{','.join(length_row)[:60]!r}, expected "
                                      "'Collection Length (seconds):, …'")
    length_s = text.number(length_line, length_row[0], length_row[1], f"{layout}: ")
    if not 0 < length_s <= MAX_LENGTH_S:
        raise EmgFileError(text.path, f"{layout}: line {length_line}: a collection length of "
                                      f"{length_s:g} s", "the header is damaged; export it again")
    sensors = _filled(rows[3][1])
    names_line, names = rows[5]
    while names and not names[-1]:
        names.pop()
    if any(_RATE_IN_NAME.search(n) for n in names):
        raise EmgFileError(text.path, f"{layout} (Discover 1.4 layout, rates in the channel "
                                      f"names such as {names[0]!r}): line {names_line}: the "
                                      "channel names give no unit, so the EMG's unit is not in "
                                      "the file", "export it again with Trigno Discover 1.5 or "
                                      "later, or from EMGworks")
    timed = any(n.endswith(TIME_SERIES) for n in names)
    layout += " with a time column per channel" if timed else " without time columns"
    rates_line, rates = rows[6]
    start = 7
    if len(rows) > 7 and _is_period_row(rows[7][1], names):
        start = 8  # Discover 2.x: the sample periods (and, right of them, the markers' heading)
    data = rows[start:]
    if not data:
        raise EmgFileError(text.path, f"{layout}: no samples after the header",
                           "the export is cut or empty; export it again")
    channels, skipped, beyond = [], Counter(), []
    for j, cell in enumerate(names):
        if cell.endswith(TIME_SERIES) or not cell:
            continue
        match = _UNIT.match(cell)
        channel, unit = (match["name"], match["unit"].strip()) if match else (cell, "")
        sensor = sensors[j] if j < len(sensors) else (sensors[-1] if sensors else "")
        name = f"{sensor}: {channel}" if sensor else channel
        if not channel.upper().startswith("EMG"):
            skipped[f"{channel} ({unit})" if unit else channel] += 1
            continue
        scale = volts_per_unit(unit)
        if scale is None:
            raise EmgFileError(text.path, f"{layout}: line {names_line}: {name} is in "
                                          f"{unit!r}, not a voltage",
                               "export the EMG in V, mV or µV")
        rate = _rate(rates[j] if j < len(rates) else "", hz=True, comma=text.decimal_comma)
        if rate is None:
            raise EmgFileError(text.path, f"{layout}: line {rates_line}, column {j + 1}: "
                                          f"{(rates[j] if j < len(rates) else '')!r} is not "
                                          f"the rate of {name} ('… Hz')")
        if timed:
            if j == 0 or not names[j - 1].endswith(TIME_SERIES):
                raise EmgFileError(text.path, f"{layout}: line {names_line}: column {j} is "
                                              f"{(names[j - 1] if j else '')!r}, expected the "
                                              f"time column '{channel}{TIME_SERIES}' of {name}")
            t, v, at = _pairs(text, layout, data, j - 1, j, name)
            if t.size >= 2:
                _check_rate(text, layout, name, t, rate)
            channels.append(Channel(name, rate, float(t[0]) if t.size else 0.0, v * scale, at,
                                    t, unit))
        else:
            v, at, extra = _column(text, layout, data, j, name, round(length_s * rate))
            channels.append(Channel(name, rate, 0.0, v * scale, at, unit=unit))
            if extra:
                beyond.append(f"{name} ({extra})")
    notes = [f"cells beyond the collection length ({length_s:g} s) ignored: "
             f"{', '.join(beyond)}"] if beyond else []
    return combine(text, layout, "discover-csv", channels, _listed(skipped), notes)


# ------------------------------------------------------------------ cells
def _pairs(text: Text, layout: str, rows, ti: int, vi: int, name: str):
    """The (time, value) pairs of one channel from its two columns, to their first empty
    row; a cell after that, or a time without a value, is refused."""
    t, v, at = [], [], []
    ended = None
    for line, cells in rows:
        tc = cells[ti] if ti < len(cells) else ""
        vc = cells[vi] if vi < len(cells) else ""
        if not tc and not vc:
            ended = ended or line
            continue
        if ended is not None or not tc or not vc:
            raise EmgFileError(text.path, f"{layout}: line {line}: {name} has "
                                          + ("a sample after its column ended (line "
                                             f"{ended})" if ended is not None else
                                             "a value but no time" if not tc else
                                             "a time but no value"),
                               "the export is damaged; export it again")
        t.append(text.number(line, "X[s]" if layout.startswith("an EMGworks") else
                             f"{name} time", tc, f"{layout}: "))
        v.append(text.number(line, name, vc, f"{layout}: "))
        at.append(line)
    return np.array(t), np.array(v), np.array(at, dtype=int)


def _column(text: Text, layout: str, rows, j: int, name: str, expected: int):
    """The first `expected` samples of a basic Discover column, and how many cells follow
    them before the column runs out (counted and ignored); a cell after an empty one is
    refused."""
    v, at = [], []
    extra = 0
    ended = None
    for line, cells in rows:
        cell = cells[j] if j < len(cells) else ""
        if not cell:
            ended = ended or line
            continue
        if ended is not None:
            raise EmgFileError(text.path, f"{layout}: line {line}: {name} has a sample after "
                                          f"its column ended (line {ended})",
                               "the export is damaged; export it again")
        if len(v) == expected:
            extra += 1
            continue
        v.append(text.number(line, name, cell, f"{layout}: "))
        at.append(line)
    if len(v) < expected - 1:  # the last sample of a channel may fall on the length's rounding
        raise EmgFileError(text.path, f"{layout}: {name} has {len(v)} samples; the collection "
                                      f"length and its rate say {expected}",
                           "the export is cut; export it again")
    return np.array(v), np.array(at, dtype=int), extra


def _check_rate(text: Text, layout: str, name: str, t: np.ndarray, rate: float) -> None:
    step = float(np.median(np.diff(t)))
    if not abs(step * rate - 1.0) < 0.01:
        raise EmgFileError(text.path, f"{layout}: the time column of {name} steps by "
                                      f"{step:g} s, its rate {rate:g} Hz says {1 / rate:g} s")


def _is_period_row(cells: list[str], names: list[str]) -> bool:
    inside = [c for c in cells[:len(names)] if c]
    return bool(inside) and all(_PERIOD.match(c) for c in inside)


def _rate(cell: str, hz: bool = False, comma: bool = False) -> float | None:
    text = cell.strip()
    if hz:
        match = _RATE.match(text)
        if not match:
            return None
        text = match["rate"]
    if comma:
        text = text.replace(",", ".")
    try:
        value = float(text)
    except ValueError:
        return None
    return value if np.isfinite(value) and value > 0 else None


def _filled(cells: list[str]) -> list[str]:
    """The sensor row with each sensor's name carried over its blank columns."""
    out, last = [], ""
    for cell in cells:
        last = cell or last
        out.append(last)
    return out


def _listed(counts: Counter) -> list[str]:
    return [f"{name} ×{n}" if n > 1 else name for name, n in counts.items()]
