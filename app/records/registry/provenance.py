"""Where a trial was recorded and what its file was (issue 32, "Stations"; schema v10): the
station that recorded each trial and ran each plan, and the SHA-256 of each trial's file as
it was finished.

Why: several robot stations record into one registry. A trial row then says which station
recorded it (a fault seen on one robot, a file to look for on its disk), a plan run which
station ran it (a console that starts again marks only its own interrupted runs, never a
run another station is still carrying out), and the checksum lets any station, or a study
reading a copy of the trial store, prove that the file it reads is the one that was
recorded (`file_checksum`, Registry.verify_trial_file).

A station's id (`station_id`) is `REHAB_STATION` when set (a department names its robots:
robot-1, robot-2), else the computer's host name: one per console, stable across restarts,
readable in a list.

Schema v10 adds the columns and seals them (each row checked against its v9 seal first);
registries before it have NULL there ("not recorded").
"""

from __future__ import annotations

import hashlib
import os
import re
import socket
from collections.abc import Mapping

from app.errors import InvalidRecordError
from app.records.registry import seals

ENV_STATION = "REHAB_STATION"
STATION = re.compile(r"[A-Za-z0-9][A-Za-z0-9._-]{0,63}")
"""A station id: a host name's characters, at most 64."""
CHECKSUM = re.compile(r"[0-9a-f]{64}")
_CHUNK = 1 << 20


def station_id(environ: Mapping[str, str] | None = None) -> str:
    """This console's station id: REHAB_STATION, else the host name (its first label, with
    any character a station id cannot hold replaced by '-')."""
    environ = os.environ if environ is None else environ
    if given := environ.get(ENV_STATION):
        return checked_station(given, ENV_STATION)
    host = socket.gethostname().split(".")[0] or "station"
    return re.sub(r"[^A-Za-z0-9._-]", "-", host)[:64].lstrip("._-") or "station"


def checked_station(value: object, name: str = "station") -> str:
    if not isinstance(value, str) or not STATION.fullmatch(value):
        raise InvalidRecordError(
            f"{name} {value!r} is not a station id: give 1 to 64 letters, digits, '.', '_' or "
            "'-', starting with a letter or digit (e.g. robot-2)")
    return value


def file_checksum(path: str | os.PathLike) -> str:
    """The SHA-256 of the file at `path`, hex (read in 1 MiB pieces: a long trial's file
    is hundreds of MB)."""
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        while piece := file.read(_CHUNK):
            digest.update(piece)
    return digest.hexdigest()


def checked_checksum(value: object) -> str | None:
    if value is None:
        return None
    if not isinstance(value, str) or not CHECKSUM.fullmatch(value):
        raise InvalidRecordError(f"checksum {value!r}: give a SHA-256 as 64 lower-case hex "
                                 "digits (provenance.file_checksum), or None")
    return value


# -- schema v10 ---------------------------------------------------------------------------
_CHECKSUM_CHECK = ("CHECK (checksum IS NULL OR (length(checksum) = 64 AND "
                   "checksum NOT GLOB '*[^0-9a-f]*'))")

SQLITE_V10 = (
    *seals.checked_before_resealing("trials", seals.SEALED_AT_V9["trials"]),
    *seals.checked_before_resealing("plan_runs", seals.SEALED_AT_V9["plan_runs"]),
    "ALTER TABLE trials ADD COLUMN station TEXT",
    f"ALTER TABLE trials ADD COLUMN checksum TEXT {_CHECKSUM_CHECK}",
    "ALTER TABLE plan_runs ADD COLUMN station TEXT",
    *(statement for table in ("trials", "plan_runs") for statement in (
        f"DROP TRIGGER {table}_sealed_on_insert",
        f"DROP TRIGGER {table}_sealed_on_update",
        f"UPDATE {table} SET seal = {seals.call(table, seals.sealed_at(table, 10))}",
        *seals.triggers(table, seals.sealed_at(table, 10)))),
)
"""Schema v10 on SQLite (over the columns v10 sealed: a later schema added some)."""

