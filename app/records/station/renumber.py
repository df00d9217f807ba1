"""A session or trial recorded offline whose number another station gave meanwhile, sent
under the server's next free number, and that renumbering kept in the registry (issue 32:
"syncs when the server returns, without duplicates or lost trials"; docs/stations.md,
Offline stations, "Renumbered").

While a station is cut off its standby numbers the next trial of a session as the server
would have when it was last mirrored; another station recording for the same patient
meanwhile takes the same number on the server. The sync refused such a trial, and the
station stayed offline for good: nothing let anyone resolve it. Now the sync inserts the
station's session or trial without its number and the server's numbering trigger gives it
the next free one (postgres/numbering.py: gap-free, unique, under the patient's row lock,
in the sync's one transaction); the trials keep their order.

Nothing of it is silent. Each renumbering is a row of `corrections`, the registry's sealed,
append-only audit trail of a record corrected (clinical.py; no new table, column or
migration: it already says which patient, what field, the old value and the new one, why,
who and when, and research reads its values but not its reason or its author):

* `field` 'trial_number' or 'session_number';
* `old_value` / `new_value` JSON: the trial's id, its session's number and its number as
  recorded offline, then as the registry has it (a session: its id and number);
* `reason`: the station that recorded it offline, its file (whose name keeps the number it
  was recorded under: a trial file is never renamed), and the other station's trial (or
  session) that took the number meanwhile;
* `corrected_by` 'station <name>', `corrected_at` the sync's time (UTC).
"""

from __future__ import annotations

import json
from dataclasses import dataclass

import sqlalchemy as sa

from app.records.registry.postgres.tables import metadata
from app.records.registry.values import utc_now, utc_text

NUMBERED = ("sessions", "trials")
"""The tables whose rows the server numbers: their added rows are sent without a number."""


@dataclass(frozen=True, slots=True)
class Renumbered:
    """A session or trial the sync sent under another number than it was recorded offline
    with: `session`/`trial` as recorded → `now_session`/`now_trial` (a session's
    renumbering: `trial` None), `trial_ids` the server's ids of the trials whose numbers this
    changes, `taken` who took the number ('station robot-2 recorded trial 3 meanwhile')."""

    session: int
    trial: int | None
    now_session: int
    now_trial: int | None
    trial_ids: tuple[int, ...]
    taken: str

    @property
    def line(self) -> str:
        if self.trial is None:
            return f"session {self.session} is now session {self.now_session}: {self.taken}"
        return (f"trial {self.trial} of session {self.session} is now trial {self.now_trial}: "
                f"{self.taken}")


def record_trial(conn: sa.Connection, values: dict, recorded: int, since: int,
                 ours: set[int], station: str, file: str | None = None) -> Renumbered:
    """Trial `values` (as inserted, its server id and number) recorded offline as number
    `recorded`: the renumbering kept in `corrections`. The server's trials of the session
    from number `since` (the first this sync sent there) that are not `ours` (the server
    ids of the trials this sync added) were recorded meanwhile: they took the numbers.
    `file`: the name its file was recorded under, where another station's trial has it and
    the trial is registered under a second name (secondname.py); None: its own."""
    trials, sessions = metadata.tables["trials"], metadata.tables["sessions"]
    patient, session = conn.execute(
        sa.select(sessions.c.patient_id, sessions.c.number)
        .where(sessions.c.id == values["session_id"])).one()
    others = conn.execute(
        sa.select(trials.c.number, trials.c.station, trials.c.started_at)
        .where(trials.c.session_id == values["session_id"], trials.c.number >= since,
               trials.c.id.not_in(ours))
        .order_by(trials.c.number)).all()
    # none: the trials the standby knew past the server's last were taken back meanwhile
    taken = _taken_trials(others) if others else \
        f"the server's session {session} goes up to trial {values['number'] - 1}"
    now = {"trial_id": values["id"], "session": session, "trial": values["number"]}
    named = f"its file {values['file']} keeps that number in its name" if file is None else (
        f"its file {file} keeps that number in its name; registered under the second name "
        f"{values['file']}, below")
    keep_correction(
        conn, patient, "trial_number", now | {"trial": recorded}, now,
        f"recorded on station {values['station'] or station} while the shared registry was "
        f"unreachable, as trial {recorded} of session {session} ({named}); {taken}; sent at "
        f"the sync as trial {values['number']}", station)
    return Renumbered(session, recorded, session, values["number"], (values["id"],), taken)


def record_session(conn: sa.Connection, values: dict, recorded: int, since: int,
                   ours: set[int], station: str) -> Renumbered:
    """Session `values` (as inserted) recorded offline as number `recorded`, kept as a
    trial's is (`record_trial`); its trials keep their numbers, in their new session."""
    sessions, trials = metadata.tables["sessions"], metadata.tables["trials"]
    others = conn.execute(
        sa.select(sessions.c.id, sessions.c.number, sessions.c.date)
        .where(sessions.c.patient_id == values["patient_id"], sessions.c.number >= since,
               sessions.c.id.not_in(ours))
        .order_by(sessions.c.number)).all()
    taken = "; ".join(_taken_session(conn, trials, *row) for row in others) or \
        f"the server's sessions go up to {values['number'] - 1}"
    now = {"session_id": values["id"], "session": values["number"]}
    keep_correction(
        conn, values["patient_id"], "session_number", now | {"session": recorded}, now,
        f"opened on station {station} while the shared registry was unreachable, as session "
        f"{recorded}; {taken}; sent at the sync as session {values['number']} (its trials "
        "keep their numbers and their files)", station)
    return Renumbered(recorded, None, values["number"], None, (), taken)


def said(renumbered: tuple[Renumbered, ...]) -> str:
    """The renumberings of one sync in one line for the window, the trials that one
    station's trials pushed on together: 'trials 2, 3 of session 1 are now trials 4, 5:
    station robot-2 recorded …'."""
    groups: list[list[Renumbered]] = []
    for moved in renumbered:
        last = groups[-1][-1] if groups else None
        if last is not None and moved.trial is not None and last.trial is not None \
                and (last.session, last.taken) == (moved.session, moved.taken):
            groups[-1].append(moved)
        else:
            groups.append([moved])
    lines = []
    for group in groups:
        if len(group) == 1:
            lines.append(group[0].line)
            continue
        before = ", ".join(str(m.trial) for m in group)
        after = ", ".join(str(m.now_trial) for m in group)
        lines.append(f"trials {before} of session {group[0].session} are now trials "
                     f"{after}: {group[0].taken}")
    return "; ".join(lines)


def with_trials(renumbered: Renumbered, trial_ids: list[int]) -> Renumbered:
    """A session's renumbering with the server ids of its trials this sync added."""
    return Renumbered(renumbered.session, None, renumbered.now_session, None,
                      tuple(trial_ids), renumbered.taken)


def _taken_trials(others) -> str:
    """'station robot-2 recorded trial 3 (begun … UTC) meanwhile', one clause a station."""
    by_station: dict[str, list[str]] = {}
    for number, station, started in others:
        by_station.setdefault(station or "(not recorded)", []).append(
            f"trial {number} (begun {started[:16].replace('T', ' ')} UTC)")
    return ", ".join(f"station {station} recorded {' and '.join(trials)} meanwhile"
                     for station, trials in by_station.items())


def _taken_session(conn: sa.Connection, trials: sa.Table, session_id: int, number: int,
                   date: str) -> str:
    stations = sorted({s or "(not recorded)" for (s,) in conn.execute(
        sa.select(trials.c.station).where(trials.c.session_id == session_id))})
    who = f"station {', '.join(stations)}" if stations else "another station"
    return f"{who} opened session {number} meanwhile (dated {date})"


def keep_correction(conn: sa.Connection, patient: int, field: str, old: dict, new: dict,
                    reason: str, station: str) -> None:
    """A correction this sync made (`station`'s), sealed by the server as every one."""
    corrections = metadata.tables["corrections"]
    conn.execute(sa.insert(corrections).values(
        patient_id=patient, field=field, old_value=json.dumps(old), new_value=json.dumps(new),
        reason=reason, corrected_by=f"station {station}", corrected_at=utc_text(utc_now())))
