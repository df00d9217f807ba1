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
merged into: it is refused unless `overwrite`, which replaces it.

Two exports into one folder at once (two consoles, or the window and `rehab export`) each
read the index, added their rows and replaced it: the later lost the earlier's rows, whose
files stayed unlisted. The read, merge and replace hold the folder's lock (flock on the
folder itself, so nothing is left in it), one export after the other.
"""

from __future__ import annotations

import contextlib
import csv
import fcntl
import math
import os
from collections.abc import Iterator, Mapping
from pathlib import Path

from app.exports.files import OutputExistsError, output

INDEX_KEY = "export_file"
INDEX_HEAD = ("participant", "session", "trial", INDEX_KEY)
"""The first columns of every index the console writes (app.exports.run)."""
NAMES_HEAD = ("participant", "first_name", "last_name")


def write_index(path: Path, rows: list[dict], suffix: str, overwrite: bool) -> Path:
    """The index of `rows` and of the earlier export's rows still in the folder."""
    with _merging(path.parent):
        return _write_index(path, rows, suffix, overwrite)


def _write_index(path: Path, rows: list[dict], suffix: str, overwrite: bool) -> Path:
    delimiter = "\t" if suffix == ".tsv" else ","
    earlier = _earlier(path, INDEX_HEAD, delimiter, overwrite)
    new = {row[INDEX_KEY] for row in rows}
    kept = [row for row in earlier if row.get(INDEX_KEY) not in new
            and (path.parent / row.get(INDEX_KEY, "")).is_file()]
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
    be overwritten)."""
    if not path.exists():
        return []
    try:
        with path.open(encoding="utf-8", newline="") as stream:
            reader = csv.DictReader(stream, delimiter=delimiter)
            ours = tuple(reader.fieldnames or ())[:len(head)] == head
            rows = [row for row in reader if row.get(head[0])] if ours else []
    except (OSError, UnicodeDecodeError, csv.Error):
        ours, rows = False, []
    if ours:
        return rows
    if overwrite:
        return []
    raise OutputExistsError(
        f"{path} exists and is not an index of the console's exports, so nothing was "
        "added to it and nothing was written. Choose another folder, move it, or replace "
        "it with --overwrite")


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
