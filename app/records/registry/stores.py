"""Where each trial's file is kept besides its station's data folder: the department's shared
trial store (issue 32: "trial files go to a shared trial store (a folder on the network, path
per station), and the registry records where each file is and its checksum"; schema v11).

A station writes every trial file into its own data folder (a network folder can drop in the
middle of a trial; the 2 ms loop must never wait on it) and, once the trial is finished and
its file's SHA-256 kept (provenance, v10), copies it into the store, reads the copy back and
checks it against that checksum (app.records.trialstore). Only then is the store recorded
as the file's other place (`trials.stored_in`: the store's folder; the file is at the same
relative path there as in the data folder). So a trial whose `stored_in` is set has a copy
in the store that was proven whole when it was made, and `Registry.verify_trial_file`
checks it again on demand.

Schema v11 adds the column and seals it (each row checked against its v10 seal first);
every trial before it, and every trial not copied yet, has NULL there.
"""

from __future__ import annotations

from app.errors import InvalidRecordError, RegistryError
from app.records.registry import provenance, seals
from app.records.registry.database import Database
from app.records.registry.statements import execute
from app.records.registry.trials import (
    STATUS_RECORDING,
    TRIAL_SELECT,
    Trial,
    trial_by_id,
    trials_from_rows,
)

SQLITE_V11 = (
    *seals.checked_before_resealing("trials", seals.SEALED_AT_V10["trials"]),
    "ALTER TABLE trials ADD COLUMN stored_in TEXT",
    "DROP TRIGGER trials_sealed_on_insert",
    "DROP TRIGGER trials_sealed_on_update",
    f"UPDATE trials SET seal = {seals.call('trials', seals.sealed_at('trials', 11))}",
    *seals.triggers("trials", seals.sealed_at("trials", 11)),
)
"""Schema v11 on SQLite."""


class Stores(Database):
    """The shared trial store's record of each trial (a part of Registry)."""

    def record_stored(self, trial_id: int, store: str) -> Trial:
        """Record that the trial's file was copied into the shared trial store at the folder
        `store` (absolute) and its copy proven to have the checksum kept at its end
        (app.records.trialstore does both before calling this). Refused for a trial not
        finished or without a checksum; recording the same store again changes nothing."""
        if not isinstance(store, str) or not store.startswith("/") or "\n" in store:
            raise InvalidRecordError(f"store {store!r}: give the trial store's folder as an "
                                     "absolute path")
        with self._write() as conn:
            trial = trial_by_id(conn, self.where, trial_id, lock=True)
            if trial.status == STATUS_RECORDING or trial.checksum is None:
                raise RegistryError(
                    f"trial {trial_id} has no checksum kept yet (it is not finished, or was "
                    "recorded before schema v10): a copy of it cannot be proven whole, so it "
                    "is not recorded as stored")
            if trial.stored_in != store:
                execute(conn, "UPDATE trials SET stored_in = ? WHERE id = ?",
                        (store, trial_id))
        return self.trial(trial_id)

    def record_rewritten(self, trial_id: int, checksum: str) -> Trial:
        """The SHA-256 of a finished trial's file after the console itself wrote into it
        (an assessment's task figures, imported EMG, the session's MVCs, the pose from the
        video; app.trials.rewrite, which checks the file was the one recorded first), so
        that the file can still be proven the trial's. A copy in the trial store is of the
        file before: the trial is no longer recorded as stored (the store never replaces a
        file; app.records.trialstore says so when it meets the old copy). A trial without a
        checksum is left as it is."""
        checksum = provenance.checked_checksum(checksum)
        with self._write() as conn:
            trial = trial_by_id(conn, self.where, trial_id, lock=True)
            if trial.status == STATUS_RECORDING or trial.checksum is None:
                return trial
            execute(conn, "UPDATE trials SET checksum = ?, stored_in = NULL WHERE id = ?",
                    (checksum, trial_id))
        return self.trial(trial_id)

    def trials_to_store(self, station: str | None = None) -> list[Trial]:
        """This station's finished trials with a checksum and no copy in the store yet,
        oldest first (what app.records.trialstore.store_pending copies)."""
        station = station or self.station
        # a console without a station id records none: its trials are those with none
        which, given = ("t.station IS NULL", ()) if station is None else \
            ("t.station = ?", (station,))
        with self._read() as conn:
            rows = execute(conn, TRIAL_SELECT + f" WHERE {which} AND t.status != ? "
                           "AND t.checksum IS NOT NULL AND t.stored_in IS NULL "
                           "ORDER BY t.id", (*given, STATUS_RECORDING)).fetchall()
        return trials_from_rows(rows)
