"""The registry read without writing a byte: its committed state as an in-memory copy, for
a disk too full to read it the ordinary way (issue 28, item 3).

Why: in WAL mode every connection, even a read-only one, maps the `-shm` index and may
create it and the `-wal`, and a full disk refuses that ("disk I/O error"): `rehab
trials`, `report`, `export` and the window's lists all failed while nothing needed
saving. SQLite's own way around it (`immutable=1`) ignores the WAL, which may hold the
last committed changes, and `readonly_shm=1` needs an `-shm` file that is already whole.

How: the database file is read into memory and the WAL's committed frames are applied
to it as SQLite's recovery applies them (SQLite file format, section 4 "The Write-Ahead
Log": a frame counts when its salts are the WAL header's and its cumulative checksum
holds, and the log counts up to its last such frame that commits), then the image is
opened in memory (`sqlite3.Connection.deserialize`), read-only. Nothing is written to
the disk, and nothing of the registry is changed.
"""

from __future__ import annotations

import sqlite3
import struct
from pathlib import Path

WAL_MAGIC = (0x377F0682, 0x377F0683)
WAL_HEADER = 32
FRAME_HEADER = 24
NO_ROOM = ("disk i/o error", "disk is full", "unable to open database file",
           "readonly database")
"""SQLite's words when a connection cannot make or grow the files it reads through."""


def needs_snapshot(exc: sqlite3.Error) -> bool:
    """Whether a read failed for want of room to write (then a snapshot reads instead)."""
    return isinstance(exc, sqlite3.OperationalError) and any(
        words in str(exc).lower() for words in NO_ROOM)


def _checksum(data: bytes, s0: int, s1: int, big_endian: bool) -> tuple[int, int]:
    """The WAL's running checksum over `data` (a multiple of 8 bytes), from (s0, s1)."""
    words = struct.unpack((">" if big_endian else "<") + f"{len(data) // 4}I", data)
    for i in range(0, len(words), 2):
        s0 = (s0 + words[i] + s1) & 0xFFFFFFFF
        s1 = (s1 + words[i + 1] + s0) & 0xFFFFFFFF
    return s0, s1


def committed_image(path: str | Path) -> bytes:
    """The database at `path` as its readers see it: the file with the WAL's committed
    frames applied, marked as a rollback-journal database (an image in memory has no
    WAL)."""
    path = Path(path)
    image = bytearray(path.read_bytes())
    wal_path = path.with_name(path.name + "-wal")
    wal = wal_path.read_bytes() if wal_path.exists() else b""
    if len(wal) >= WAL_HEADER:
        image = _apply_wal(image, wal)
    if len(image) >= 20:
        image[18] = image[19] = 1  # file format: legacy (rollback journal), not WAL
    return bytes(image)


def _apply_wal(image: bytearray, wal: bytes) -> bytearray:
    magic, _version, page_size, _sequence, salt1, salt2, c0, c1 = struct.unpack(
        ">8I", wal[:WAL_HEADER])
    if magic not in WAL_MAGIC or not (512 <= page_size <= 65536):
        return image  # not a WAL SQLite would use: the database file alone
    big_endian = bool(magic & 1)
    s0, s1 = _checksum(wal[:24], 0, 0, big_endian)
    if (s0, s1) != (c0, c1):
        return image
    pages: dict[int, bytes] = {}
    committed: dict[int, bytes] = {}
    size_pages = None
    offset = WAL_HEADER
    while offset + FRAME_HEADER + page_size <= len(wal):
        number, commit, f_salt1, f_salt2, f_c0, f_c1 = struct.unpack(
            ">6I", wal[offset:offset + FRAME_HEADER])
        data = wal[offset + FRAME_HEADER:offset + FRAME_HEADER + page_size]
        if (f_salt1, f_salt2) != (salt1, salt2) or number == 0:
            break
        s0, s1 = _checksum(wal[offset:offset + 8] + data, s0, s1, big_endian)
        if (s0, s1) != (f_c0, f_c1):
            break
        pages[number] = data
        if commit:
            committed.update(pages)
            pages.clear()
            size_pages = commit
        offset += FRAME_HEADER + page_size
    if size_pages is None:
        return image
    image = image[:size_pages * page_size]
    image.extend(bytes(size_pages * page_size - len(image)))
    for number, data in committed.items():
        if number <= size_pages:
            image[(number - 1) * page_size:number * page_size] = data
    return image


def snapshot_connection(path: str | Path) -> sqlite3.Connection:
    """An in-memory, read-only connection to the registry's committed state."""
    conn = sqlite3.connect(":memory:", isolation_level=None)
    try:
        conn.deserialize(committed_image(path))
        conn.execute("PRAGMA query_only = ON")
    except (OSError, sqlite3.Error):
        conn.close()
        raise
    return conn
