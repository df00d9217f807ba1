"""The registry of patients, sessions and trials: one SQLite file in the data folder.

`Registry` is the one entry point; it implements `app.records.store.RecordStore`,
the interface the rest of app and ui use. It is composed of one part per table
or concern, each a module here:

* database — connections, the write and read transactions, SQLite's errors as
  the registry's own, the online backup and the integrity checks;
* schema — the DDL of every version and the migration on opening;
* patients — registering and finding patients (pseudonymous codes);
* sessions — a patient's sittings and their numbers;
* trials — numbering (`suggest_registration`), `begin_trial` at Start,
  `finish_trial` at Stop, and listing;
* queries — the progress rows (`trial_summaries`) and `previous_trial`;
* proposals — the console's proposal for the next trial and the therapist's decision;
* plans — session plans per patient and what each run of one did (schema v7);
* clinical — a session's clinical scales, notes on sessions and trials, trials marked
  invalid (or valid again), a patient's fields corrected with their audit (schema v8);
* reanalyses — a trial's figures re-computed from its file, stored with a note saying
  which analysis made them (app.trials.reanalyse);
* values — the checks of what is given and the JSON of parameters and metrics.
* seals — every row sealed with the digest of its values, checked before it is read.
* provenance, stores — the station of each trial and its file's checksum (v10); the shared
  trial store its file was copied to (v11).

Storage in short (each module's docstring says more):

* `PRAGMA user_version` is the schema version; an older registry is copied
  aside and migrated in one transaction on opening; a newer one is refused.
* WAL journal (readers never block the writer), foreign keys on, a busy timeout,
  `synchronous=FULL` (a registered trial survives a power cut).
* On a disk too full for a WAL reader's `-shm` and `-wal` files, reads come from an
  in-memory copy of the committed state (`snapshot`: the file and the WAL's committed
  frames), and a write is refused saying the disk is full.
* Two consoles on one data folder: every write is a `BEGIN IMMEDIATE`
  transaction, so the one that reads the next number is the one that inserts
  it; the other waits (busy timeout) and then sees it. UNIQUE constraints on
  (patient, session number) and (session, trial number) back this up.
* Parameters and metrics are JSON text, so a new metric needs no schema change.
* Every row carries a seal (schema v6, `seals`): triggers compute it through a
  function only the console's connections have, and the file's structure and
  every seal are checked once for each state of the file before anything is read
  or written; a flipped bit is refused in one line, never read as written.
* Every connection lives for one call, so a `Registry` holds no connection and
  may be used from several threads.

Names live only in the `patients` table and never reach the log; every file is
named by code. WAL needs a local disk: on a network share use one console per
data folder.
"""

from __future__ import annotations

import os
from pathlib import Path

import sqlalchemy as sa

from app.errors import RegistryURLError
from app.records.datadir import DataDir, private_files
from app.records.registry.clinical import (
    CORRECTABLE,
    Clinical,
    Correction,
    Note,
    ScaleEntry,
    TrialMark,
)
from app.records.registry.database import BUSY_TIMEOUT_S
from app.records.registry.patients import (
    BIRTH_YEAR_MIN,
    CODE_LENGTH,
    HANDEDNESS,
    SEXES,
    Patient,
    Patients,
    new_code,
)
from app.records.registry.plans import PlanRun, Plans, PlanStep, StoredPlan
from app.records.registry.proposals import Proposals, StoredProposal
from app.records.registry.provenance import checked_station, station_id
from app.records.registry.queries import Queries, TrialSummary
from app.records.registry.reanalyses import Reanalyses
from app.records.registry.schema import (
    MIGRATE_V1_TO_V2,
    MIGRATE_V2_TO_V3,
    MIGRATIONS,
    SCHEMA_V1,
    SCHEMA_VERSION,
    Schema,
    check_registry_file,
    create_registry_file,
    refuse_missing_registry,
)
from app.records.registry.sessions import Session, Sessions
from app.records.registry.stores import Stores
from app.records.registry.trials import (
    KEY_PARAMETERS,
    BegunTrial,
    Registration,
    Trial,
    Trials,
    key_values,
    parameter_key,
)
from app.records.registry.url import POSTGRESQL, registry_url
from app.records.registry.values import NAME_MAX_CHARS, TEXT_MAX_CHARS

__all__ = [
    "BIRTH_YEAR_MIN",
    "BUSY_TIMEOUT_S",
    "CODE_LENGTH",
    "CORRECTABLE",
    "HANDEDNESS",
    "KEY_PARAMETERS",
    "MIGRATE_V1_TO_V2",
    "MIGRATE_V2_TO_V3",
    "MIGRATIONS",
    "NAME_MAX_CHARS",
    "SCHEMA_V1",
    "SCHEMA_VERSION",
    "SEXES",
    "TEXT_MAX_CHARS",
    "BegunTrial",
    "Correction",
    "Note",
    "Patient",
    "PlanRun",
    "PlanStep",
    "Registration",
    "Registry",
    "ScaleEntry",
    "Session",
    "StoredPlan",
    "StoredProposal",
    "Trial",
    "TrialMark",
    "TrialSummary",
    "has_registry",
    "key_values",
    "new_code",
    "open_registry",
    "parameter_key",
]


class Registry(Schema, Patients, Sessions, Plans, Clinical, Proposals, Trials, Stores,
               Queries, Reanalyses):
    """The registry of one data folder. Opening it migrates the database; with `create`
    (the window, `rehab patients add`) a missing one is created, whole, in a new or empty
    folder (app.records.registry.schema.create_registry_file); without, a missing registry
    is refused saying what the folder holds, and nothing is created.

    With `server` (a `postgresql+psycopg://` URL, app.records.registry.url) the registry is
    the department's on its PostgreSQL server, which its owner creates and migrates
    (`rehab db upgrade`); the data folder holds this station's trial files. `station`
    names this console in what it records (trials, plan runs: registry.provenance; the
    window and the commands give `station_id()`)."""

    def __init__(self, data_dir: DataDir | str | Path, *, create: bool = True,
                 server: sa.URL | None = None, station: str | None = None,
                 bounded: bool = False) -> None:
        """`bounded`: a station's window on a server, whose every wait for an answer is
        bounded (Database.bounded)."""
        self.bounded = bounded
        if not isinstance(data_dir, DataDir):
            data_dir = DataDir(Path(data_dir).expanduser().absolute())
        self.data_dir = data_dir
        self.station = None if station is None else checked_station(station)
        if server is not None:
            # the department's registry on its server (docs/stations.md); the data folder
            # keeps this station's trial files
            self.server, self.path = server, None
            data_dir.ensure()
            self._migrate()
            if self._reads_codes_only():
                self._writer.dispose()  # again, reading research's views by name
                del self._writer, self._reader_engine
                self.research = True
            return
        self.path = data_dir.registry_path
        if not create:
            refuse_missing_registry(data_dir)
        data_dir.ensure()
        if check_registry_file(self.path, data_dir.trials_dir) is None:
            if not create:
                refuse_missing_registry(data_dir)  # gone meanwhile
            create_registry_file(data_dir)
        self._migrate()
        private_files(self.path)



    def _reads_codes_only(self) -> bool:
        """Whether this login is a researcher's: it may not read a patient's name."""
        with self._read() as conn:
            return not conn.exec_driver_sql(
                "SELECT has_column_privilege('public.patients', 'first_name', 'SELECT')"
            ).scalar_one()


def open_registry(data_dir: DataDir, *, create: bool = True,
                  station: str | None = None, standby: bool = False) -> Registry:
    """The registry this console uses (what the window and every command open): the one
    the private registry URL file names (app.records.registry.url, `registry.url` in the
    config folder), else the data folder's SQLite registry. A SQLite URL must name the data
    folder's own registry file, which keeps the trial files beside it; a PostgreSQL URL
    names the department's server, the data folder keeping this station's trial files.
    `station`: this console's id (by default provenance.station_id()). `standby` (the
    window): on a server, a station that goes on recording when it cannot be reached
    (app.records.station.StationRegistry, a RecordStore like the registry)."""
    location = registry_url(data_dir)
    station = station or station_id()
    if location.engine == POSTGRESQL:
        if standby:
            from app.records.station import StationRegistry  # it builds on this package

            return StationRegistry(data_dir, location.url, station=station)
        return Registry(data_dir, create=create, server=location.url, station=station)
    if os.path.abspath(location.path) != os.path.abspath(data_dir.registry_path):
        raise RegistryURLError(
            f"{location.source} names the SQLite registry {location.path}, but this console's "
            f"data folder {data_dir.root} has its own ({data_dir.registry_path}): choose that "
            "folder as the data folder, or remove the URL file to use the data folder's")
    return Registry(data_dir, create=create, station=station)


def has_registry(data_dir: DataDir) -> bool:
    """Whether this console has a registry to ask (open_registry) without creating one: a
    server's, or the data folder's file."""
    return registry_url(data_dir).engine == POSTGRESQL or data_dir.registry_path.is_file()
