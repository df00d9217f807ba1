"""A trial recorded offline whose file's name another station's trial has on the server,
registered under the name its numbers give, a second name of the same file in this
station's data folder (issue 32: "syncs when the server returns, without duplicates or lost
trials"; docs/stations.md, Offline stations, "A file's name taken").

A trial file's name is its patient's code, session, number and start to the second
(app.records.datadir.trial_stem), and the registry keeps each name once (`trials.file`
UNIQUE: the shared trial store holds every station's files at their names). Two stations
whose clocks differ (a patient moved from robot-1 to robot-2, robot-2's clock a minute
behind) make one name for the patient's trial N, robot-1 offline and robot-2 online. The
sync refused robot-1's trial, and the station never came back online.

Now the sync (sync.py) registers that trial under the name its numbers on the server give
(renumbered: it is trial N+1 or later there), and before the server's transaction commits
this station's data folder gets that name as a hard link to the file recorded (where the
file system has no links, a copy made aside, its SHA-256 checked against the checksum kept,
put in place): the file recorded is never renamed, changed or written over, and no file is
ever written over by the second name (a file of another content there refuses the sync in
one line; the same file there, from an attempt whose answer was lost, is taken as it is).
A `trial_file` correction, sealed and append-only like the renumbering's (renumber.py),
says which name the file had, which it has in the registry, and whose trial has the first.

The trial that has the name may be this station's own, still recording on the server: a
Start whose registration reached the server as the network dropped, its answer lost, so
the station registered the trial again on its standby in the same second and recorded it
there. That row is finished in the sync as recording lost, saying why: left recording, the
station's next start (app.trials.finalize.finish_interrupted) would finalize it from the
file of its name, this trial's, writing that row's metrics into it.
"""

from __future__ import annotations

import contextlib
import datetime
import errno
import hashlib
import os
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import sqlalchemy as sa

from app.errors import RegistryError
from app.records.datadir import DataDir, trial_stem
from app.records.registry.postgres.tables import metadata
from app.records.registry.provenance import file_checksum
from app.records.registry.values import utc_now, utc_text
from app.records.station.renumber import keep_correction
from device.recording.trialfile import STATUS_RECORDING
from device.safewrite import OutputRefused, atomic_output, sync_folder

_NO_LINKS = (errno.EPERM, errno.ENOTSUP, errno.EOPNOTSUPP, errno.EXDEV, errno.EMLINK)
"""What os.link says on a file system that cannot link (FAT, exFAT, some network shares)."""

_CHUNK = 1 << 20


class SecondNameRefused(RegistryError):
    """The second name of a trial's file cannot be made in the data folder (the line says
    why); nothing was written over."""


@dataclass(frozen=True, slots=True)
class SecondName:
    """Trial `trial_id` (the server's) recorded as `file`, registered as `second`."""

    trial_id: int
    file: str
    second: str
    checksum: str | None


@dataclass(frozen=True, slots=True)
class Holder:
    """The server's trial that has a file's name: its id, station and status, and it in
    words ("station robot-2's trial 2 of session 1 (begun … UTC)")."""

    trial_id: int
    station: str | None
    status: str
    words: str


def holders(conn: sa.Connection, files: list[str]) -> dict[str, Holder]:
    """Which of `files` the server's trials have, and which trial. One round trip."""
    if not files:
        return {}
    trials, sessions = metadata.tables["trials"], metadata.tables["sessions"]
    rows = conn.execute(
        sa.select(trials.c.file, trials.c.id, trials.c.station, trials.c.status,
                  trials.c.number, sessions.c.number, trials.c.started_at)
        .join(sessions, sessions.c.id == trials.c.session_id)
        .where(trials.c.file.in_(files)))
    return {file: Holder(trial_id, station, status,
                         f"station {station or '(not recorded)'}'s trial {number} of session "
                         f"{session} (begun {started[:19].replace('T', ' ')} UTC)")
            for file, trial_id, station, status, number, session, started in rows}


def numbered_name(conn: sa.Connection, values: dict) -> tuple[str, int]:
    """The name and number trial `values` (its session the server's) takes: the next
    number of its session, the patient's row locked first as the server's numbering trigger
    locks it (so it is the number the trigger checks at the insert), and the file's name
    for the session's number and that one, in the same folder."""
    trials, sessions, patients = (metadata.tables[t] for t in ("trials", "sessions",
                                                                "patients"))
    code, session = conn.execute(
        sa.select(patients.c.code, sessions.c.number)
        .join(patients, patients.c.id == sessions.c.patient_id)
        .where(sessions.c.id == values["session_id"])
        .with_for_update(of=patients, key_share=True)).one()
    number = conn.execute(sa.select(sa.func.coalesce(sa.func.max(trials.c.number), 0) + 1)
                          .where(trials.c.session_id == values["session_id"])).scalar_one()
    started = datetime.datetime.fromisoformat(values["started_at"])
    recorded = PurePosixPath(values["file"])
    name = recorded.parent / (trial_stem(code, session, number, started) + recorded.suffix)
    return str(name), number


def record(conn: sa.Connection, values: dict, recorded: str, holder: Holder,
           station: str) -> SecondName:
    """The second name of trial `values` (as inserted) kept in `corrections`; the holder,
    when it is this station's own trial left recording, finished (the module's doc)."""
    sessions = metadata.tables["sessions"]
    patient = conn.execute(sa.select(sessions.c.patient_id)
                           .where(sessions.c.id == values["session_id"])).scalar_one()
    recorder = values["station"] or station
    lost = holder.station == recorder and holder.status == STATUS_RECORDING
    if lost:
        _finish_lost(conn, holder.trial_id, values, recorded)
    keep_correction(
        conn, patient, "trial_file", {"trial_id": values["id"], "file": recorded},
        {"trial_id": values["id"], "file": values["file"]},
        f"the file {recorded} of the trial recorded on station {recorder} while the shared "
        f"registry was unreachable has the name of {holder.words}, which the registry keeps "
        f"once: registered under {values['file']}, the name its numbers give, a second name "
        f"of the same file in station {recorder}'s data folder (the file itself unchanged)"
        + ("; that trial, registered as the network dropped and never recorded on the "
           "server, is finished as recording lost" if lost else ""), station)
    return SecondName(values["id"], recorded, values["file"], values["checksum"])


def _finish_lost(conn: sa.Connection, trial_id: int, values: dict, recorded: str) -> None:
    trials = metadata.tables["trials"]
    conn.execute(sa.update(trials).where(trials.c.id == trial_id,
                                         trials.c.status == STATUS_RECORDING).values(
        status="recording_lost", metrics="{}", ended_at=utc_text(utc_now()),
        end_reason=(f"registered as the network dropped, its answer lost: the station "
                    f"registered the trial again offline and recorded it there, as the file "
                    f"{recorded}, sent at the sync as trial {values['number']} under the name "
                    f"{values['file']}; no file of this trial's own")))


def make(data_dir: DataDir, names: tuple[SecondName, ...]) -> None:
    """Give each file its second name in `data_dir` (the module's doc); SecondNameRefused
    (one line) when one cannot be, the names made before it taken away again."""
    made: list[Path] = []
    try:
        for name in names:
            if _make(data_dir, name):
                made.append(data_dir.resolve(name.second))
    except BaseException:
        for path in made:  # made by this attempt, whose transaction does not commit
            with contextlib.suppress(OSError):
                path.unlink()
        raise


def _make(data_dir: DataDir, name: SecondName) -> bool:
    """Whether the second name was made now (False: there already, the same file)."""
    source, target = data_dir.resolve(name.file), data_dir.resolve(name.second)
    if not source.exists():  # a trial whose file was never written: its name alone
        return False
    try:
        os.link(source, target, follow_symlinks=False)
    except FileExistsError:
        if _same(source, target, name.checksum):
            return False
        raise SecondNameRefused(
            f"{target} holds another file than trial {name.trial_id}'s {source}, whose name "
            "another station's trial has on the server: it is kept; move it aside to let "
            "the trial be sent under that name") from None
    except OSError as exc:
        if exc.errno not in _NO_LINKS:
            raise SecondNameRefused(f"the second name {target} of {source} cannot be made "
                                    f"({exc.strerror or exc})") from None
        _copy(source, target, name)
    sync_folder(target.parent)
    return True


def _same(source: Path, target: Path, checksum: str | None) -> bool:
    with contextlib.suppress(OSError):
        if target.is_symlink():
            return False
        if os.path.samefile(source, target):
            return True
        return checksum is not None and file_checksum(target) == checksum
    return False


def _copy(source: Path, target: Path, name: SecondName) -> None:
    """The second name as a copy of the file: written aside, hashed as written, put in
    place only when it is the file recorded, never over a file (device.safewrite)."""
    digest = hashlib.sha256()
    try:
        with atomic_output(target) as copy, open(source, "rb") as reader:
            while piece := reader.read(_CHUNK):
                digest.update(piece)
                copy.write(piece)
            expected = name.checksum or file_checksum(source)
            if digest.hexdigest() != expected:
                raise SecondNameRefused(
                    f"{source}, trial {name.trial_id}'s file, is not the one recorded (its "
                    "SHA-256 differs from the checksum kept at its end): it was not copied "
                    f"to {target}; restore it from the trial store or a backup")
    except (OSError, OutputRefused) as exc:
        raise SecondNameRefused(f"the second name {target} of {source} cannot be made "
                                f"({exc})") from None
