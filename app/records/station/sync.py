"""What a station recorded while the department's server could not be reached, sent to the
server when it answers again (issue 32: "syncs when the server returns, without duplicates
or lost trials"; docs/stations.md, Offline stations).

The work is the standby's rows that are not as mirrored (mirror.changes): rows the station
added (a session, trials, their proposals, notes, scales, marks, plan runs) and rows it
changed (a trial begun online and finished offline, a proposal decided, a patient's field
corrected). They are replayed onto the server in the tables' order, in ONE transaction of
the server: all of them arrive or none does, so a sync cut off halfway leaves nothing
behind and is simply made again.

* An added row gets the server's next id; the rows that name it (a trial's session, a
  proposal's next trial, a note's trial) are given that id.
* A changed row is written over the server's only if the server's row is still what was
  mirrored (its seal): otherwise another station changed it meanwhile and the sync is
  refused, naming the row.
* A session or trial the station added is sent without its number: the server's numbering
  trigger gives it the next free one (gap-free, unique: postgres/numbering.py). Where
  another station took the number meanwhile it differs from the one recorded offline, and
  that renumbering is kept in the registry, sealed, naming the trial that took it
  (renumber.py); the trials keep their order and their files their names. It was refused,
  and the station stayed offline for good: nothing let anyone resolve it.
* A trial whose file's name another station's trial has on the server (two stations'
  clocks apart: one name for the patient's trial N) is registered under the name its new
  number gives, a second name of the same file in the data folder (secondname.py; the
  station makes it before the transaction commits). It was refused for good too.
* The server's other rules hold on each row (refused, naming the row).
* Every row's seal on the server must equal the seal of the values sent (the same digest on
  both engines): what arrived is exactly what the station recorded, ids aside.
* A sync whose commit was sent but not answered (the network dropped at that moment) may
  have arrived: the trials it adds are looked up by their file first (one another
  station's trial has: among that patient's, by start and station); all there means it
  did, and it is not sent twice.

Refused (a row another station changed, a row the server's rules refuse, a seal that
differs), the standby and its trial files stay as they are and the station goes on
recording there; nothing is lost, and the line says what to resolve.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import sqlalchemy as sa

from app.errors import RegistryError
from app.records.registry import seals
from app.records.registry.postgres.tables import REGISTRY_TABLES, metadata
from app.records.station import renumber, secondname
from app.records.station.mirror import Change, key_columns
from app.records.station.renumber import Renumbered
from app.records.station.secondname import SecondName

log = logging.getLogger(__name__)


class SyncRefused(RegistryError):
    """The station's offline records cannot be sent as they are: another station changed
    the same patient's records meanwhile, or the server's rules refused a row (the line
    says which)."""


@dataclass(frozen=True, slots=True)
class Synced:
    """What a sync sent: rows per table (added, changed), the trials' new ids, the
    sessions and trials sent under another number than recorded offline, and the trials
    registered under a second name of their file (made in the data folder before the
    transaction commits: secondname.make)."""

    added: dict[str, int]
    changed: dict[str, int]
    trial_ids: dict[int, int]  # the standby's id -> the server's
    renumbered: tuple[Renumbered, ...] = ()
    second_names: tuple[SecondName, ...] = ()

    @property
    def trials(self) -> int:
        return self.added.get("trials", 0)

    @property
    def renumbering(self) -> str:
        """The renumberings in one line for the window ('' when none)."""
        return renumber.said(self.renumbered)


def already_sent(conn: sa.Connection, work: list[Change]) -> bool:
    """Whether this work arrived already (a sync whose commit was not answered): every
    trial it adds is on the server, by its file, its start to the microsecond and its
    station (a file's name gives the start to the second only: another station may have
    numbered the same trial in that second). Some but not all is refused."""
    added = [_values(c) for c in work if c.table == "trials" and c.mirrored is None]
    if not added:
        return False
    trials = metadata.tables["trials"]
    found = {tuple(r) for r in conn.execute(
        sa.select(trials.c.file, trials.c.started_at, trials.c.station)
        .where(trials.c.file.in_([v["file"] for v in added])))}
    held = {file for file, _, _ in found}
    there = sum((v["file"], v["started_at"], v["station"]) in found
                or (v["file"] in held and _under_a_second_name(conn, v)) for v in added)
    if there == len(added):
        return True
    if there:
        raise SyncRefused(f"{there} of the {len(added)} trials this station recorded offline "
                          "are on the server already and the others are not")
    return False


def replay(conn: sa.Connection, work: list[Change], where: str, station: str) -> Synced:
    """Send `work` (mirror.changes, in its order) in the caller's transaction on `conn`;
    `station`, the station sending it, names who renumbered what (renumber.py)."""
    ids: dict[str, dict[int, int]] = {table: {} for table in REGISTRY_TABLES}
    added = dict.fromkeys(REGISTRY_TABLES, 0)
    changed = dict.fromkeys(REGISTRY_TABLES, 0)
    renumbered: list[Renumbered] = []
    sessions_renumbered: dict[int, int] = {}  # the server's session id -> its index above
    first: dict[str, dict[int, int]] = {table: {} for table in renumber.NUMBERED}
    holders = secondname.holders(conn, [_values(c)["file"] for c in work
                                        if c.table == "trials" and c.mirrored is None])
    second_names: list[SecondName] = []
    for change in work:
        values = _mapped(change, ids)
        file = values.get("file") if change.table == "trials" else None
        renamed = change.mirrored is None and file in holders
        try:
            if change.mirrored is None:
                recorded = values.get("number")
                if renamed:  # its name another station's trial has: the one its number gives
                    values["file"], values["number"] = secondname.numbered_name(conn, values)
                seal = _add(conn, change.table, values, ids[change.table],
                            numbered=not renamed)
                added[change.table] += 1
            else:
                seal = _change(conn, change, values)
                if seal is None:
                    log.warning("%s was decided on the server by another station's trial "
                                "meanwhile, the trial numbered before this station's: its "
                                "decision stands", _named(change))
                    continue
                changed[change.table] += 1
        except sa.exc.IntegrityError as exc:  # the server's rules refused the row
            diag = getattr(exc.orig, "diag", None)
            reason = getattr(diag, "message_primary", None) or str(exc.orig).splitlines()[0]
            raise SyncRefused(f"{_named(change)} was refused by {where} ({reason})") from None
        if change.mirrored is None and change.table in renumber.NUMBERED:
            # the number this sync first sent in the session (of the patient): what the
            # server holds from there on, but ours, was recorded meanwhile
            owner = values["session_id" if change.table == "trials" else "patient_id"]
            since = first[change.table].setdefault(owner, recorded)
            if values["number"] != recorded:  # another station took the number
                ours = set(ids[change.table].values())
                if change.table == "sessions":  # its trials keep their numbers: named below
                    sessions_renumbered[values["id"]] = len(renumbered)
                if change.table == "sessions":
                    renumbered.append(renumber.record_session(conn, values, recorded, since,
                                                              ours, station))
                else:
                    renumbered.append(renumber.record_trial(
                        conn, values, recorded, since, ours, station,
                        file if renamed else None))
        if renamed:
            second_names.append(secondname.record(conn, values, file, holders[file], station))
        sent = seals.seal_of(change.table, *(values[c] for c in seals.SEALED[change.table]))
        if seal != sent:
            raise SyncRefused(f"{_named(change)} did not arrive unchanged at {where} (its "
                              "seal there differs from the values sent)")
    trials = metadata.tables["trials"]
    for session, index in sessions_renumbered.items():  # the trials whose session it is
        renumbered[index] = renumber.with_trials(renumbered[index], list(conn.execute(
            sa.select(trials.c.id).where(trials.c.session_id == session,
                                         trials.c.id.in_(ids["trials"].values()))
            .order_by(trials.c.number)).scalars()))
    return Synced({t: n for t, n in added.items() if n},
                  {t: n for t, n in changed.items() if n}, dict(ids["trials"]),
                  tuple(renumbered), tuple(second_names))


def _under_a_second_name(conn: sa.Connection, values: dict) -> bool:
    """Whether trial `values`, whose file's name another station's trial has, is on the
    server under a second name (secondname.py): a trial of that patient begun at its start
    to the microsecond by its station."""
    trials, sessions = metadata.tables["trials"], metadata.tables["sessions"]
    holder = trials.alias("holder")
    patient = (sa.select(sessions.c.patient_id)
               .join(holder, holder.c.session_id == sessions.c.id)
               .where(holder.c.file == values["file"]).scalar_subquery())
    return conn.execute(
        sa.select(trials.c.id).join(sessions, sessions.c.id == trials.c.session_id)
        .where(sessions.c.patient_id == patient, trials.c.started_at == values["started_at"],
               trials.c.station == values["station"])).first() is not None


def _values(change: Change) -> dict:
    return dict(zip(seals.SEALED[change.table], change.row[:-1], strict=True))


def _mapped(change: Change, ids: dict[str, dict[int, int]]) -> dict:
    """The row's values with the ids of rows added before it replaced by the server's."""
    values = _values(change)
    for foreign in metadata.tables[change.table].foreign_keys:
        name, target = foreign.parent.name, foreign.column.table.name
        if values[name] in ids[target]:
            values[name] = ids[target][values[name]]
    return values


def _add(conn: sa.Connection, table: str, values: dict, new_ids: dict[int, int], *,
         numbered: bool = True) -> str:
    """Insert the row; a session or trial without its number (the server's next free one,
    written into `values`) unless not `numbered` (its number given: the trigger checks it
    is the next)."""
    t = metadata.tables[table]
    if "id" not in key_columns(table):
        return conn.execute(sa.insert(t).values(values).returning(t.c.seal)).scalar_one()
    local = values.pop("id")
    if table in renumber.NUMBERED:
        if numbered:
            values["number"] = None
        server_id, seal, values["number"] = conn.execute(
            sa.insert(t).values(values).returning(t.c.id, t.c.seal, t.c.number)).one()
    else:
        server_id, seal = conn.execute(sa.insert(t).values(values)
                                       .returning(t.c.id, t.c.seal)).one()
    new_ids[local] = values["id"] = server_id
    return seal


def _change(conn: sa.Connection, change: Change, values: dict) -> str | None:
    """Write the changed row over the server's, if the server's is still as mirrored; None
    when it is a proposal another station's trial decided meanwhile (`_decided_meanwhile`:
    the server's decision stands)."""
    t = metadata.tables[change.table]
    keys = key_columns(change.table)
    where = sa.and_(*(t.c[k] == values[k] for k in keys))
    row = conn.execute(sa.select(*(t.c[c] for c in seals.SEALED[change.table]), t.c.seal)
                       .where(where).with_for_update()).one_or_none()
    if (None if row is None else row[-1]) != change.mirrored:
        if _decided_meanwhile(change, values, row):
            return None
        raise SyncRefused(f"{_named(change)} was changed on the server by another station "
                          "while this one was offline")
    return conn.execute(sa.update(t).where(where).values(
        {c: v for c, v in values.items() if c not in keys}).returning(t.c.seal)).scalar_one()


def _decided_meanwhile(change: Change, values: dict, row: sa.Row | None) -> bool:
    """Whether `change` is a pending proposal this station's offline trial decided that a
    trial of another station decided meanwhile on the server, nothing else of it changed
    on either side. Both trials came next after the proposal, each on its own station; on
    the server the other station's took the next number (this station's is sent after it:
    renumber.py), so the proposal's decision is that trial's, and the server's stands.
    Refused, every number conflict with a proposal pending (the window records one after
    each trial) stayed refused, renumbered or not."""
    if change.table != "proposals" or row is None or row.decision == "pending":
        return False
    columns = seals.SEALED["proposals"]
    undecided = {"decision": "pending", "next_trial_id": None, "decided_at": None}

    def pending(v: dict) -> str:
        return seals.seal_of("proposals", *((v | undecided)[c] for c in columns))

    return pending(values) == change.mirrored == pending(dict(zip(columns, row[:-1],
                                                                   strict=True)))


def _named(change: Change) -> str:
    values = _values(change)
    if change.table == "trials":
        return f"the trial {values['file']}"
    key = "/".join(str(values[k]) for k in key_columns(change.table))
    return f"{change.table} row {key}"
