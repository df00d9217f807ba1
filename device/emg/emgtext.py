"""What every EMG text file shares: the one-line error, the data read from it, the bounded
read, the rows (comma- or semicolon-separated) and the numbers (decimal point or comma).

A lab whose Windows is set to a language with a decimal comma (Dutch, German, French, …)
gets Delsys exports separated by `;` with decimal commas: a public Python reader of
exports "from the Trigno delsys system at the VU" reads them with `sep=';', decimal=','`,
the type "delsys exports … when you[r] language setting is dutch" (GitHub code,
`read_delsys(filename, filetype="dutch")`, 7 header rows: a Discover export). A file is
read that way when one of its first lines has a `;` and no comma (its header rows: a
comma-separated export's rows all have commas, even where a sensor's name holds a `;`); a
number may then carry a comma for its decimal point.

A file that is not UTF-8 but has no NUL byte is read as Windows-1252, the code page of
the Windows PCs the Delsys software runs on (`µV` is byte 0xB5 there), and a note says so;
a byte Windows-1252 does not define, or a NUL, makes it "not a text file".
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.errors import capitalised
from device.errors import DeviceError
from device.safeinput import InputRefused, read_bytes

MAX_BYTES = 2 * 2**30  # a 2 GiB CSV is a mistake, not an EMG recording of a session
SNIFF_LINES = 20


class EmgFileError(DeviceError):
    """An EMG file cannot be read; the message is the one line shown."""

    def __init__(self, path: object, problem: str, advice: str = "") -> None:
        self.path, self.problem = path, problem
        text = f"EMG file {path}: {problem}"
        super().__init__(f"{text}. {capitalised(advice)}" if advice else text)


@dataclass(frozen=True, slots=True, eq=False)
class EmgData:
    """EMG read from a file: `samples` (M, C) in volts at `t_s` (M,), the file's own
    clock in seconds, `rate_hz`, one name per channel, `source` (the layout: `trigno-csv`,
    `emgworks-csv`, `discover-csv` or `csv`), and notes on what was skipped or changed."""

    names: tuple[str, ...]
    rate_hz: float
    t_s: np.ndarray
    samples: np.ndarray
    source: str
    path: Path
    notes: tuple[str, ...] = ()


@dataclass(frozen=True, slots=True)
class Text:
    """A file's lines and how its cells are written."""

    path: Path
    lines: list[str]
    delimiter: str = ","
    notes: tuple[str, ...] = ()

    @property
    def decimal_comma(self) -> bool:
        return self.delimiter == ";"

    def rows(self, start: int = 0) -> list[tuple[int, list[str]]]:
        """(line number from 1, stripped cells) of each row from line index `start` that
        is not a blank line and not a `#` comment; a row of empty cells (`,,,`) is kept:
        inside the data it is a gap."""
        out = []
        k = start
        try:
            reader = csv.reader(self.lines[start:], delimiter=self.delimiter)
            for k, row in enumerate(reader, start=start + 1):
                cells = [c.strip() for c in row]
                if not self.lines[k - 1].strip() or (cells and cells[0].startswith("#")):
                    continue
                out.append((k, cells))
        except csv.Error as exc:  # a cell over the csv module's limit (131,072 characters), …
            raise EmgFileError(self.path, f"line {k + 1} cannot be read as CSV ({exc})",
                               "the file may not be an EMG export") from None
        return out

    def number(self, line: int, column: str, cell: str, what: str = "") -> float:
        """The number in `cell` (line `line`, column `column`); `what` names the layout in
        the refusal."""
        text = cell.strip()
        if self.decimal_comma:
            text = text.replace(",", ".")
        try:
            value = float(text)
        except ValueError:
            raise EmgFileError(self.path, f"{what}line {line}, column {column!r}: "
                                          f"{cell.strip()!r} is not a number",
                               "the file may be cut or edited by hand") from None
        if not math.isfinite(value):
            raise EmgFileError(self.path, f"{what}line {line}, column {column!r}: "
                                          f"{cell.strip()} is not finite")
        return value


MAX_EMG_V = 1.0
"""No surface EMG reaches a volt at an amplifier's input (a Delsys Trigno sensor's range is
±11 mV, Brain Products' BrainAmp and LiveAmp a few hundred mV at most): a channel that
does holds µV or mV numbers read as volts (software that writes µV and no unit), which
would be stored a million times too large and set against MVCs in volts."""


def beyond_range(name: str, volts: np.ndarray, said: str) -> str | None:
    """What is wrong, in words, when a channel's samples reach MAX_EMG_V (its name, its
    peak and how its unit was known: `said`, "in mV as the file says"), else None."""
    peak = float(np.max(np.abs(volts))) if volts.size else 0.0
    if not peak > MAX_EMG_V:
        return None
    return (f"{name} reaches {peak:.4g} V ({said}), more than surface EMG ever is "
            f"({MAX_EMG_V:g} V): its numbers are in another unit")


def check_range(path: Path, layout: str, name: str, volts: np.ndarray, said: str) -> None:
    """Refuse a file's channel beyond MAX_EMG_V (beyond_range) in one line."""
    problem = beyond_range(name, volts, said)
    if problem:
        raise EmgFileError(path, f"{layout}: {problem}",
                           "give the unit in the file (a column 'biceps [uV]', or µV, mV in "
                           "the export's settings) and import it again")


def read_text(path: Path) -> Text:
    """The file's lines, read bounded and without blocking (device.safeinput: a pipe would
    hang the reader, /dev/zero fill the memory), with its delimiter."""
    try:
        if not path.exists():
            raise EmgFileError(path, "no such file", "check the path")
        if path.is_dir():
            raise EmgFileError(path, "is a folder, not a file", "give the exported .csv file")
        raw = read_bytes(path, what="EMG file", max_bytes=MAX_BYTES)
    except InputRefused as exc:
        raise EmgFileError(path, exc.problem, "give the exported .csv file") from None
    except OSError as exc:
        raise EmgFileError(path, f"cannot be read ({exc.strerror or exc})") from None
    notes: tuple[str, ...] = ()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        try:
            if b"\0" in raw:
                raise UnicodeDecodeError("cp1252", raw, 0, 1, "a NUL byte")
            text = raw.decode("cp1252")
        except UnicodeDecodeError:
            raise EmgFileError(path, "is not a text file (neither UTF-8 nor Windows-1252)",
                               "export the recording as CSV from the EMG software") from None
        notes = ("read as Windows-1252 text (the file is not UTF-8)",)
    lines = text.splitlines()
    if not any(line.strip() for line in lines):
        raise EmgFileError(path, "is empty", "export the recording again")
    head = [line for line in lines if line.strip()][:SNIFF_LINES]
    semicolons = any(";" in line and "," not in line for line in head)
    return Text(path, lines, ";" if semicolons else ",", notes)
