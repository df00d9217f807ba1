"""The registry's tables and their history: the DDL of every schema version and the
migration of an older registry to this console's.

* `PRAGMA user_version` is the schema version; `MIGRATIONS` lists the forward
  steps from 0, the first of which is the historic v1 DDL, kept as it shipped.
* Opening an older registry copies it aside (`registry.sqlite3.v1-<UTC>.bak`)
  and migrates it in one transaction; a newer one is refused.
* The journal is WAL (readers never block the writer). WAL needs a local disk:
  on a network share use one console per data folder.
"""

from __future__ import annotations

import contextlib
import datetime
import logging
import os
import shutil
import sqlite3
from pathlib import Path

from app.errors import RegistryError, SchemaError
from app.records.datadir import (
    ENV_DATA_DIR,
    SIMULATED,
    DataDir,
    foreign_entries,
    registered_trial_count,
)
from app.records.registry import numbering, proposals, provenance, seals, stores
from app.records.registry.database import Database, rollback
from app.records.registry.postgres import registry_version
from app.records.registry.snapshot import needs_snapshot
from app.records.safewrite import OutputRefused, atomic_output, atomic_path, folded

# The registry's one logger, named as it was before the registry had modules.
log = logging.getLogger(__package__)

# Historic: the DDL exactly as v1 shipped. Never edit; add a migration instead.
SCHEMA_V1 = (
    """CREATE TABLE patients (
        id INTEGER PRIMARY KEY,
        code TEXT NOT NULL UNIQUE,
        first_name TEXT,
        last_name TEXT,
        birth_year INTEGER,
        side TEXT CHECK (side IS NULL OR side IN ('right', 'left')),
        body_mass_kg REAL,
        upper_arm_m REAL,
        forearm_m REAL,
        shoulder_x_m REAL,
        shoulder_y_m REAL,
        notes TEXT NOT NULL DEFAULT '',
        created_at TEXT NOT NULL
    )""",
    """CREATE TABLE sessions (
        id INTEGER PRIMARY KEY,
        patient_id INTEGER NOT NULL REFERENCES patients (id) ON DELETE RESTRICT,
        number INTEGER NOT NULL CHECK (number >= 1),
        date TEXT NOT NULL,
        therapist TEXT NOT NULL DEFAULT '',
        notes TEXT NOT NULL DEFAULT '',
        UNIQUE (patient_id, number)
    )""",
    """CREATE TABLE trials (
        id INTEGER PRIMARY KEY,
        session_id INTEGER NOT NULL REFERENCES sessions (id) ON DELETE RESTRICT,
        number INTEGER NOT NULL CHECK (number >= 1),
        parameters TEXT NOT NULL,
        file TEXT NOT NULL UNIQUE,
        metrics TEXT NOT NULL DEFAULT '{}',
        status TEXT NOT NULL CHECK (status IN
            ('recording', 'complete', 'stopped_early', 'faulted', 'recording_lost')),
        started_at TEXT NOT NULL,
        ended_at TEXT,
        patient_kind TEXT,
        UNIQUE (session_id, number)
    )""",
)

# v2: which backend ran each trial (NULL for trials registered before v2, when
# it was not kept), and where a session took place (clinic room, home visit).
MIGRATE_V1_TO_V2 = (
    "ALTER TABLE trials ADD COLUMN backend TEXT",
    "ALTER TABLE sessions ADD COLUMN location TEXT NOT NULL DEFAULT ''",
)

# v3: the console's proposal for the trial after each trial (app.trials.progression) and
# what the therapist did with it; trials before v3 have none.
MIGRATE_V2_TO_V3 = (
    """CREATE TABLE proposals (
        trial_id INTEGER PRIMARY KEY REFERENCES trials (id) ON DELETE RESTRICT,
        proposal TEXT NOT NULL,
        decision TEXT NOT NULL DEFAULT 'pending'
            CHECK (decision IN ('pending', 'accepted', 'changed', 'kept')),
        next_trial_id INTEGER REFERENCES trials (id) ON DELETE RESTRICT,
        proposed_at TEXT NOT NULL,
        decided_at TEXT
    )""",
)

# v4: why a trial ended as it did, in the words the therapist saw (a fault's message, a
# lost recording's cause), so it survives in the registry even when the trial file does
# not hold it (a full disk, a dead recorder); '' for trials before v4 and normal ends.
MIGRATE_V3_TO_V4 = (
    "ALTER TABLE trials ADD COLUMN end_reason TEXT NOT NULL DEFAULT ''",
)

# v5: the assistance levels each trial ran with, read from its file when it was finished
# (app.records.assistance.AssistanceInEffect.to_dict: the level at the exercise's start,
# at its end and each live change with its time), not the level it was built with; NULL
# for trials before v5 and until a trial is finished.
MIGRATE_V4_TO_V5 = (
    "ALTER TABLE trials ADD COLUMN assistance TEXT",
)

# v6: every row sealed with the digest of its values, kept by triggers, checked before
# every read and write (app.records.registry.seals): a flipped bit is refused, not read.
MIGRATE_V5_TO_V6 = seals.migration()

# v7: session plans (core.plan) saved per patient, each change a new row (`based_on` the
# one it changed, `template` the built-in template it was first copied from), and what
# each run of a plan did: its trials (one per block's round) and its rests in order, and
# how it ended (app.records.registry.plans). Sealed from the start.
MIGRATE_V6_TO_V7 = (
    """CREATE TABLE plans (
        id INTEGER PRIMARY KEY,
        patient_id INTEGER NOT NULL REFERENCES patients (id) ON DELETE RESTRICT,
        name TEXT NOT NULL,
        plan TEXT NOT NULL,
        template TEXT NOT NULL DEFAULT '',
        based_on INTEGER REFERENCES plans (id) ON DELETE RESTRICT,
        created_at TEXT NOT NULL,
        seal TEXT
    )""",
    """CREATE TABLE plan_runs (
        id INTEGER PRIMARY KEY,
        plan_id INTEGER NOT NULL REFERENCES plans (id) ON DELETE RESTRICT,
        started_at TEXT NOT NULL,
        ended_at TEXT,
        status TEXT NOT NULL CHECK (status IN
            ('running', 'complete', 'stopped', 'emergency_stop', 'faulted', 'interrupted')),
        end_reason TEXT NOT NULL DEFAULT '',
        seal TEXT
    )""",
    """CREATE TABLE plan_steps (
        run_id INTEGER NOT NULL REFERENCES plan_runs (id) ON DELETE RESTRICT,
        step INTEGER NOT NULL CHECK (step >= 1),
        block INTEGER NOT NULL CHECK (block >= 1),
        round INTEGER NOT NULL CHECK (round >= 1),
        kind TEXT NOT NULL CHECK (kind IN ('trial', 'rest')),
        trial_id INTEGER UNIQUE REFERENCES trials (id) ON DELETE RESTRICT,
        planned_s REAL NOT NULL,
        taken_s REAL,
        seal TEXT,
        PRIMARY KEY (run_id, step),
        CHECK ((kind = 'trial') = (trial_id IS NOT NULL))
    )""",
    *(statement for table in ("plans", "plan_runs", "plan_steps")
      for statement in seals.triggers(table, seals.sealed_at(table, 7))),
)

# v8 (issue 31): the norms' covariates sex and handedness on the patient; the clinical
# scales a therapist records per session (app.records.scales: Fugl-Meyer UE motor, ARAT,
# Modified Ashworth, pain, fatigue; who and when); notes per session and per trial; a
# trial's validity marks (invalid with a reason, restored by a later mark); corrections of
# a patient's measurements (field, old, new, who, when, why) beside the row they changed.
# Every new table is sealed and append-only (seals.append_only): its history is the
# record. The patients' seal now covers the two new columns: each row is checked against
# its v7 seal before it is sealed again, so damage is not laundered by the upgrade.
MIGRATE_V7_TO_V8 = (
    *seals.checked_before_resealing("patients", seals.SEALED_AT_V7["patients"]),
    "ALTER TABLE patients ADD COLUMN sex TEXT CHECK (sex IS NULL OR sex IN ('female', 'male'))",
    "ALTER TABLE patients ADD COLUMN handedness TEXT "
    "CHECK (handedness IS NULL OR handedness IN ('right', 'left'))",
    "DROP TRIGGER patients_sealed_on_insert",
    "DROP TRIGGER patients_sealed_on_update",
    f"UPDATE patients SET seal = {seals.call('patients', seals.sealed_at('patients', 8))}",
    *seals.triggers("patients", seals.sealed_at("patients", 8)),
    """CREATE TABLE scales (
        id INTEGER PRIMARY KEY,
        session_id INTEGER NOT NULL REFERENCES sessions (id) ON DELETE RESTRICT,
        scale TEXT NOT NULL CHECK (scale IN
            ('fugl_meyer', 'arat', 'ashworth', 'pain', 'fatigue')),
        total INTEGER CHECK ((total IS NULL) = (scale = 'ashworth')),
        detail TEXT NOT NULL DEFAULT '{}',
        rater TEXT NOT NULL CHECK (length(rater) > 0),
        recorded_at TEXT NOT NULL,
        seal TEXT
    )""",
    """CREATE TABLE notes (
        id INTEGER PRIMARY KEY,
        session_id INTEGER NOT NULL REFERENCES sessions (id) ON DELETE RESTRICT,
        trial_id INTEGER REFERENCES trials (id) ON DELETE RESTRICT,
        text TEXT NOT NULL CHECK (length(text) > 0),
        author TEXT NOT NULL CHECK (length(author) > 0),
        written_at TEXT NOT NULL,
        seal TEXT
    )""",
    """CREATE TABLE trial_marks (
        id INTEGER PRIMARY KEY,
        trial_id INTEGER NOT NULL REFERENCES trials (id) ON DELETE RESTRICT,
        valid INTEGER NOT NULL CHECK (valid IN (0, 1)),
        reason TEXT NOT NULL CHECK (length(reason) > 0),
        marked_by TEXT NOT NULL CHECK (length(marked_by) > 0),
        marked_at TEXT NOT NULL,
        seal TEXT
    )""",
    """CREATE TABLE corrections (
        id INTEGER PRIMARY KEY,
        patient_id INTEGER NOT NULL REFERENCES patients (id) ON DELETE RESTRICT,
        field TEXT NOT NULL,
        old_value TEXT NOT NULL,
        new_value TEXT NOT NULL,
        reason TEXT NOT NULL CHECK (length(reason) > 0),
        corrected_by TEXT NOT NULL CHECK (length(corrected_by) > 0),
        corrected_at TEXT NOT NULL,
        seal TEXT
    )""",
    "CREATE INDEX scales_by_session ON scales (session_id)",
    "CREATE INDEX notes_by_session ON notes (session_id)",
    "CREATE INDEX trial_marks_by_trial ON trial_marks (trial_id)",
    "CREATE INDEX corrections_by_patient ON corrections (patient_id)",
    *(statement for table in ("scales", "notes", "trial_marks", "corrections")
      for statement in (*seals.triggers(table, seals.sealed_at(table, 8)),
                        *seals.append_only(table))),
)

MIGRATIONS: tuple[tuple[int, tuple[str, ...]], ...] = (
    (1, SCHEMA_V1),
    (2, MIGRATE_V1_TO_V2),
    (3, MIGRATE_V2_TO_V3),
    (4, MIGRATE_V3_TO_V4),
    (5, MIGRATE_V4_TO_V5),
    (6, MIGRATE_V5_TO_V6),
    (7, MIGRATE_V6_TO_V7),
    (8, MIGRATE_V7_TO_V8),
    (9, numbering.SQLITE_V9),
    (10, provenance.SQLITE_V10),
    (11, stores.SQLITE_V11),
    (12, proposals.SQLITE_V12),
    (13, proposals.SQLITE_V13),
)
SCHEMA_VERSION = MIGRATIONS[-1][0]


class Schema(Database):
    """The schema version of the registry file, and bringing it up to date."""

    def schema_version(self) -> int:
        with self._read() as conn:
            if self.on_server:
                return registry_version(conn) or 0
            return conn.exec_driver_sql("PRAGMA user_version").scalar_one()

    def _migrate(self) -> None:
        if self.on_server:
            self._check_server()
            return
        try:
            self._bring_up_to_date()
        except RegistryError as exc:
            if not isinstance(exc.__cause__, sqlite3.Error) or not needs_snapshot(exc.__cause__):
                raise
            # a full disk: a registry already up to date is read from a copy in memory
            version = self.schema_version()
            if version != SCHEMA_VERSION:
                raise RegistryError(
                    f"the registry {self.path} needs an update to schema v{SCHEMA_VERSION} "
                    f"(it is v{version}), which cannot be written: {exc.__cause__}. Free "
                    "space on its disk, then try again") from exc

    def _bring_up_to_date(self) -> None:
        with self._connection() as conn:
            mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            if mode.lower() != "wal":
                log.warning("registry %s: journal mode is %s, not WAL (a network disk?); "
                            "use one console at a time on this data folder", self.path, mode)
            version = conn.execute("PRAGMA user_version").fetchone()[0]
            if version > SCHEMA_VERSION:
                raise self._too_new(version)
            if version == SCHEMA_VERSION:
                return
            if version > 0:
                self._back_up(conn, version)
            conn.execute("BEGIN IMMEDIATE")
            try:
                # Another console may have migrated while this one waited for the lock.
                version = conn.execute("PRAGMA user_version").fetchone()[0]
                if version > SCHEMA_VERSION:
                    raise self._too_new(version)
                for target, statements in MIGRATIONS:
                    if target <= version:
                        continue
                    try:
                        for statement in statements:
                            conn.execute(statement)
                    except sqlite3.Error as exc:
                        raise SchemaError(
                            f"the registry {self.path} could not be updated to schema "
                            f"v{target} ({exc}); nothing was changed, it is still v{version}. "
                            "Keep the file and report this with it"
                        ) from exc
                    conn.execute(f"PRAGMA user_version = {target}")
                    log.info("registry %s: schema migrated from v%d to v%d",
                             self.path, target - 1, target)
                problems = conn.execute("PRAGMA foreign_key_check").fetchall()
                if problems:
                    raise SchemaError(
                        f"registry {self.path}: {len(problems)} record(s) point to missing "
                        "patients or sessions; the migration was not applied. Restore the "
                        "registry from a backup"
                    )
            except BaseException:
                rollback(conn)
                raise
            conn.execute("COMMIT")

    def _check_server(self) -> None:
        """A server's registry is created and migrated by its owner (`rehab db upgrade`),
        never by a station opening it: a station only checks that it is today's."""
        version = self.schema_version()
        if version == SCHEMA_VERSION:
            return
        if version > SCHEMA_VERSION:
            raise self._too_new(version)
        state = "holds no registry" if version == 0 else f"holds a registry of schema v{version}"
        raise SchemaError(
            f"the database {self.where} {state}; this console needs schema "
            f"v{SCHEMA_VERSION}: its owner runs `rehab db upgrade` (README, \"Several "
            "stations\")")

    def _too_new(self, version: int) -> SchemaError:
        return SchemaError(
            f"the registry {self.where} has schema v{version}, written by a newer console; "
            f"this one reads up to v{SCHEMA_VERSION}. Update the console"
        )

    def _back_up(self, conn: sqlite3.Connection, version: int) -> None:
        stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
        target = self.path.with_name(f"{self.path.name}.v{version}-{stamp}.bak")
        try:
            # the registry's own copy: whole or not at all, 0600 from the start, never over
            # a copy another console made this second (app.records.safewrite)
            with atomic_path(target, owned=True) as temporary, \
                    contextlib.closing(sqlite3.connect(temporary)) as copy:
                conn.backup(copy)
        except OutputRefused as exc:
            if os.path.lexists(target):
                return  # another console kept this second's copy
            raise RegistryError(f"the registry {self.path} was not updated to schema "
                                f"v{SCHEMA_VERSION}: its copy could not be kept first "
                                f"({exc})") from None
        log.info("registry %s: copy of schema v%d kept as %s before migrating",
                 self.path, version, target.name)


SQLITE_HEADER = b"SQLite format 3\x00"


def check_registry_file(path: Path, trials_dir: Path) -> bool | None:
    """True when a registry file is there, None when none is; refuse a registry file that
    would be taken for a new, empty one: a file of 0 bytes or that is not a SQLite
    database (a copy is kept beside it, the file left as it is), one that cannot be read,
    and a missing registry beside existing trial files. Opening any of them would start an
    empty registry and orphan every trial recorded so far. (A registry is never created
    empty, create_registry_file: a file of 0 bytes is never a console's registry being
    made.)"""
    try:
        with path.open("rb") as stream:
            header = stream.read(len(SQLITE_HEADER))
    except FileNotFoundError:
        count = registered_trial_count(trials_dir)
        if count:
            raise RegistryError(
                f"the registry {path} is missing, but {trials_dir} holds {count} trial "
                "file(s): restore the registry from a backup (a registry.sqlite3.v*.bak "
                "beside it, or your own copy), or move the trials folder away to start a "
                "new registry; the console will not start an empty one beside them") from None
        return None
    except OSError as exc:
        raise RegistryError(f"the registry {path} cannot be read ({exc.strerror or exc}); "
                            "check its permissions, or restore it from a backup") from exc
    if header == SQLITE_HEADER:
        return True
    what = "empty (0 bytes)" if not header else "not a SQLite database"
    kept = _keep_damaged(path)
    copy = f"a copy is kept as {kept.name}" if kept else "no copy of it could be kept"
    raise SchemaError(
        f"{path} is not a registry database ({what}); nothing was changed and {copy}. "
        "Restore the registry from a backup (a registry.sqlite3.v*.bak beside it, or your "
        "own copy) and start again")


def _keep_damaged(path: Path) -> Path | None:
    """A copy of a damaged registry beside it (`registry.sqlite3.damaged-<UTC>`), for
    whoever repairs it: a new file only, whole, 0600 (the patients' records; shutil.copy2
    gave it the damaged file's mode and replaced a copy of the same second); None when it
    could not be made."""
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
    for counter in range(1, 10):
        kept = path.with_name(f"{path.name}.damaged-{stamp}"
                              + (f"-{counter}" if counter > 1 else ""))
        try:
            with open(path, "rb") as source, atomic_output(kept, owned=True) as copy:
                shutil.copyfileobj(source, copy)
        except OutputRefused:
            if os.path.lexists(kept):
                continue  # a copy of this second is there already: another name
            return None
        except OSError:
            return None
        return kept
    return None


def create_registry_file(data_dir: DataDir) -> None:
    """A new registry in `data_dir`, whole: every table built and the schema version set in
    a temporary file beside it (0600, WAL), which is then linked into place. A console
    opening the same new folder at the same moment sees no registry or a whole one, never
    an empty file it would take for a damaged registry; when two create one, the first
    link wins and the other's temporary is dropped. Refused in a folder that already holds
    other things (a typo'd --data-dir must not start a registry in someone's documents)."""
    path = data_dir.registry_path
    _refuse_foreign_folder(data_dir)
    try:
        with atomic_path(path, owned=True) as temporary:
            with contextlib.closing(seals.register(
                    sqlite3.connect(temporary, isolation_level=None))) as conn:
                conn.execute("PRAGMA journal_mode = WAL")
                conn.execute("BEGIN IMMEDIATE")
                for _, statements in MIGRATIONS:
                    for statement in statements:
                        conn.execute(statement)
                conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
                conn.execute("COMMIT")
            # closing the only connection checkpointed the WAL into the file and removed it
            for suffix in ("-wal", "-shm"):
                with contextlib.suppress(OSError):
                    os.unlink(f"{temporary}{suffix}")
    except OutputRefused as exc:
        if os.path.lexists(path):
            return  # another console made it first: theirs is the registry
        raise RegistryError(f"cannot create the registry {path}: {exc}") from None
    except sqlite3.Error as exc:
        raise RegistryError(f"cannot create the registry {path}: {folded(exc)}. Check the "
                            "disk's free space and the folder's permissions") from None
    log.info("registry %s: created (schema v%d)", path, SCHEMA_VERSION)


def _refuse_foreign_folder(data_dir: DataDir) -> None:
    others = foreign_entries(data_dir.root)
    if others:
        raise RegistryError(
            f"no registry in {data_dir.root}, which holds other things ({others}): a new "
            "registry starts only in a new or empty folder. Check the data folder (it came "
            f"from the {data_dir.source}), or give a new folder for a new registry")


def refuse_missing_registry(data_dir: DataDir) -> None:
    """RegistryError saying what is where the registry should be, unless it is there: for
    a command that reads the registry, which never starts one (a typo must not leave an
    empty registry anywhere)."""
    root = data_dir.root
    if os.path.lexists(data_dir.registry_path):
        return
    if not os.path.lexists(root):
        what = "that folder does not exist"
    elif not os.path.isdir(root):
        what = "that is a file, not a folder"
    else:
        others = foreign_entries(root)
        count = registered_trial_count(data_dir.trials_dir)
        simulated = data_dir.trials_dir / SIMULATED
        empty = ("it holds only `rehab run`'s unregistered simulated trials"
                 if simulated.is_dir() and any(simulated.rglob("*.h5")) else
                 "the folder is empty")
        what = (empty if not others and not count else
                f"the folder holds {count} trial file(s) but no registry: restore the "
                "registry from a backup" if count else f"the folder holds {others}")
    raise RegistryError(
        f"no registry in {root} ({what}). Check the data folder (it came from the "
        f"{data_dir.source}: --data-dir, {ENV_DATA_DIR}, the setting data_dir or the "
        "default), or register a first patient there (`rehab patients add`) to start one")
