"""A batch export's index (`trials.csv` / `trials.tsv`) and names file (`names.csv`), merged
with those of an earlier export into the same folder.

Exporting patient after patient into one folder (the data folder's `exports/<format>` is
every export's default) used to be refused because of the index alone, and with
`--overwrite` the new index listed only the new trials while the earlier trials' files
stayed beside it, unlisted. As a BIDS export adds to its dataset (participants.tsv,
app.exports.bids), the index now keeps the earlier rows whose files are still there (by
`export_file`), the new export's rows replacing those of the same file; the names file
keeps the other participants. A trial's own files are still replaced only with
`overwrite` (app.exports.files.refuse_existing).

A file of that name the console did not write (its header is not an index's) is not
merged into: it is refused unless `overwrite`, which replaces it. An index of the
console's that is damaged (a line that is not UTF-8 or not CSV, a row of another length
than the header, an `export_file` that is empty, absolute or climbs out of the folder) is
refused in one line naming the line, even with `overwrite`: merging would silently drop
its rows or keep a row naming a file elsewhere, replacing it would leave the earlier
trials' files unlisted. An earlier row whose file is no longer in the folder (removed
since, or its name damaged) is dropped and said in one note of the export's result.

Two exports into one folder at once (two consoles, or the window and `rehab export`) each
read the index, added their rows and replaced it: the later lost the earlier's rows, whose
files stayed unlisted. The read, merge and replace hold the folder's lock (flock on the
folder itself, so nothing is left in it), one export after the other.
"""

from __future__ import annotations

import contextlib
import csv
import fcntl
import io
import logging
import math
import os
from collections.abc import Iterator, Mapping
from pathlib import Path, PurePosixPath, PureWindowsPath

from app.exports.files import ExportError, OutputExistsError, output
from device.safeinput import InputRefused, read_bytes

log = logging.getLogger(__name__)

INDEX_KEY = "export_file"
INDEX_HEAD = ("participant", "session", "trial", INDEX_KEY)
"""The first columns of every index the console writes (app.exports.run)."""
NAMES_HEAD = ("participant", "first_name", "last_name")


class IndexDamaged(ExportError):
    """An earlier export's index or names file is the console's but damaged: refused,
    whatever `overwrite`, so its rows are neither silently dropped nor kept."""


def write_index(path: Path, rows: list[dict], suffix: str, overwrite: bool,
                notes: list[str] | None = None) -> Path:
    """The index of `rows` and of the earlier export's rows still in the folder; a note
    appended to `notes` when earlier rows were dropped because their files are gone."""
    with _merging(path.parent):
        return _write_index(path, rows, suffix, overwrite, notes)


def _write_index(path: Path, rows: list[dict], suffix: str, overwrite: bool,
                 notes: list[str] | None) -> Path:
    delimiter = "\t" if suffix == ".tsv" else ","
    earlier = _earlier(path, INDEX_HEAD, delimiter, overwrite)
    new = {row[INDEX_KEY] for row in rows}
    others = [row for row in earlier if row[INDEX_KEY] not in new]
    there = [(path.parent / row[INDEX_KEY]).is_file() for row in others]
    kept = [row for row, found in zip(others, there, strict=True) if found]
    gone = [row[INDEX_KEY] for row, found in zip(others, there, strict=True) if not found]
    if gone:
        note = (f"{len(gone)} earlier row(s) of {path.name} dropped: their files are no "
                f"longer in {path.parent} (first: {gone[0]})")
        log.warning("%s", note)
        if notes is not None:
            notes.append(note)
    columns: dict[str, None] = {}
    for row in (*kept, *rows):
        columns.update(dict.fromkeys(row))
    with output(path, overwrite=True, text=True) as stream:
        writer = csv.writer(stream, delimiter=delimiter, lineterminator="\n")
        writer.writerow(columns)
        writer.writerows([row.get(c, "") for c in columns] for row in kept)
        writer.writerows([cell(row.get(c)) for c in columns] for row in rows)
    return path


def write_names(path: Path, names: Mapping, suffix: str, overwrite: bool) -> Path:
    """The names file of `names` ({code: (first, last)}) and of the earlier export's other
    participants."""
    with _merging(path.parent):
        return _write_names(path, names, suffix, overwrite)


def _write_names(path: Path, names: Mapping, suffix: str, overwrite: bool) -> Path:
    delimiter = "\t" if suffix == ".tsv" else ","
    merged = {row["participant"]: (row.get("first_name", ""), row.get("last_name", ""))
              for row in _earlier(path, NAMES_HEAD, delimiter, overwrite)}
    merged |= {code: (first or "", last or "") for code, (first, last) in names.items()}
    with output(path, overwrite=True, text=True) as stream:
        writer = csv.writer(stream, delimiter=delimiter, lineterminator="\n")
        writer.writerow(NAMES_HEAD)
        writer.writerows((code, first, last) for code, (first, last) in sorted(merged.items()))
    return path


@contextlib.contextmanager
def _merging(folder: Path) -> Iterator[None]:
    """The export folder locked while an index is read, merged and replaced (a folder
    that cannot be opened or locked, a share without locks, is written unlocked, as
    before)."""
    try:
        fd = os.open(folder, os.O_RDONLY | os.O_DIRECTORY)
    except OSError:
        yield
        return
    try:
        with contextlib.suppress(OSError):
            fcntl.flock(fd, fcntl.LOCK_EX)
        yield
    finally:
        os.close(fd)  # the lock goes with it


def check_mergeable(path: Path, suffix: str, overwrite: bool) -> None:
    """Refuse, before anything is written, an index or names file the console did not
    write (OutputExistsError unless `overwrite`)."""
    head = NAMES_HEAD if path.stem == "names" else INDEX_HEAD
    _earlier(path, head, "\t" if suffix == ".tsv" else ",", overwrite)


def _earlier(path: Path, head: tuple[str, ...], delimiter: str, overwrite: bool
             ) -> list[dict]:
    """The rows of the file there (none when there is none, or when a foreign file is to
    be overwritten); IndexDamaged when it is the console's but damaged."""
    if not os.path.lexists(path):
        return []
    try:  # the checked read: a pipe put there would have hung the export
        data = read_bytes(path, what="the index")
    except InputRefused:
        data = None
    ours, rows, problem = _parsed(data, head, delimiter) if data is not None else (
        False, [], None)
    if problem is not None:
        raise IndexDamaged(
            f"{path} is an index of the console's exports but {problem}, so nothing was "
            "added to it and nothing was written. Correct that line, or move the file "
            "away (the earlier trials' files then stay in the folder, unlisted)")
    if ours:
        return rows
    if overwrite:
        return []
    raise OutputExistsError(
        f"{path} exists and is not an index of the console's exports, so nothing was "
        "added to it and nothing was written. Choose another folder, move it, or replace "
        "it with --overwrite")


def _parsed(data: bytes, head: tuple[str, ...], delimiter: str
            ) -> tuple[bool, list[dict], str | None]:
    """(whether the header is the console's, its rows, what is damaged or None)."""
    first = data.split(b"\n", 1)[0].rstrip(b"\r")
    try:
        header = next(csv.reader([first.decode("utf-8")], delimiter=delimiter), [])
    except (UnicodeDecodeError, csv.Error):
        return False, [], None
    if tuple(header)[:len(head)] != head:
        return False, [], None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = data[:exc.start].count(b"\n") + 1
        return True, [], f"line {line} is not UTF-8 text"
    reader = csv.reader(io.StringIO(text, newline=""), delimiter=delimiter, strict=True)
    rows = []
    try:
        next(reader)
        for cells in reader:
            if not any(cells):
                continue
            if len(cells) != len(header):
                return True, [], (f"line {reader.line_num} has {len(cells)} cell(s) where "
                                  f"the header has {len(header)}")
            row = dict(zip(header, cells, strict=True))
            problem = _file_problem(row[head[-1]]) if head == INDEX_HEAD else None
            if problem is not None:
                return True, [], f"line {reader.line_num} {problem}"
            if row[head[0]]:
                rows.append(row)
    except csv.Error as exc:
        return True, [], f"line {reader.line_num} is not CSV ({exc})"
    return True, rows, None


def _file_problem(name: str) -> str | None:
    """What is wrong with an index's `export_file` cell (a path relative to the export
    folder, as run.py writes it), or None."""
    if not name:
        return f"names no {INDEX_KEY}"
    posix, windows = PurePosixPath(name), PureWindowsPath(name)
    if posix.is_absolute() or windows.is_absolute() or windows.drive or \
            name.startswith(("/", "\\")):
        return f"names the absolute path {name!r}, outside the export folder"
    if ".." in posix.parts or ".." in windows.parts:
        return f"names {name!r}, outside the export folder"
    return None


def cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if math.isfinite(value):
            return repr(value)
        return "NaN" if math.isnan(value) else ("Inf" if value > 0 else "-Inf")
    return str(value)
