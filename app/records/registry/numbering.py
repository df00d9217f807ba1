"""Session and trial numbers without gaps or repeats, on both engines (issue 32, schema v9).

A patient's sessions are numbered 1, 2, 3, … and each session's trials 1, 2, 3, …: a number
given must be the next one (a repeat is refused naming when that number was used; a number
past the next is refused, since it would leave a gap), a number never changes once given,
and only the last trial of a session (or the last session of a patient, with no trials) may
be taken back (`withdraw_trial`: a trial whose file was never written).

Where the rule lives:

* In the registry's code (`refuse_number`): a refusal the therapist reads, naming the
  number to use, on both engines alike.
* In the database, so that no program writing to it can break it: on PostgreSQL the
  server's triggers (postgres/numbering.py, with the row lock that lets stations number for
  one patient at once); on SQLite the triggers below (schema v9). SQLite lets one writer in
  at a time (BEGIN IMMEDIATE), so its triggers need no lock; `RAISE` takes a fixed text, so
  their words are general and the code's refusal, which comes first, is the specific one.

Before v9 a SQLite registry let a therapist type any unused number. Gaps already there
stay (the triggers look at the highest number, not at every one): what was recorded is
kept as it was.
"""

from __future__ import annotations

import datetime

from app.errors import DuplicateNumberError

_GAP = "numbers have no gaps and no repeats: give the next one"

SQLITE_V9 = (
    f"""CREATE TRIGGER sessions_numbered BEFORE INSERT ON sessions
        WHEN NEW.number IS NOT (SELECT coalesce(max(number), 0) + 1 FROM sessions
                                WHERE patient_id = NEW.patient_id)
        BEGIN SELECT RAISE(ABORT, 'a session number is not its patient''s next: session
            {_GAP}'); END""",
    f"""CREATE TRIGGER trials_numbered BEFORE INSERT ON trials
        WHEN NEW.number IS NOT (SELECT coalesce(max(number), 0) + 1 FROM trials
                                WHERE session_id = NEW.session_id)
        BEGIN SELECT RAISE(ABORT, 'a trial number is not its session''s next: trial
            {_GAP}'); END""",
    """CREATE TRIGGER sessions_numbers_kept BEFORE UPDATE OF number, patient_id ON sessions
        WHEN NEW.number IS NOT OLD.number OR NEW.patient_id IS NOT OLD.patient_id
        BEGIN SELECT RAISE(ABORT, 'a session keeps its number and its patient'); END""",
    """CREATE TRIGGER trials_numbers_kept BEFORE UPDATE OF number, session_id ON trials
        WHEN NEW.number IS NOT OLD.number OR NEW.session_id IS NOT OLD.session_id
        BEGIN SELECT RAISE(ABORT, 'a trial keeps its number and its session'); END""",
    """CREATE TRIGGER sessions_only_the_last_goes BEFORE DELETE ON sessions
        WHEN EXISTS (SELECT 1 FROM sessions WHERE patient_id = OLD.patient_id
                     AND number > OLD.number)
        BEGIN SELECT RAISE(ABORT, 'a session cannot be taken back: a later one exists, and
            numbers have no gaps'); END""",
    """CREATE TRIGGER trials_only_the_last_goes BEFORE DELETE ON trials
        WHEN EXISTS (SELECT 1 FROM trials WHERE session_id = OLD.session_id
                     AND number > OLD.number)
        BEGIN SELECT RAISE(ABORT, 'a trial cannot be taken back: a later one exists, and
            numbers have no gaps'); END""",
)
"""Schema v9 on SQLite: the rule held by the database (postgres/numbering.py's, without
the lock)."""


def refuse_number(what: str, number: int, next_number: int, *, whose: str,
                  used_on: datetime.datetime | datetime.date | None, advice: str = ""
                  ) -> DuplicateNumberError:
    """The refusal of `number` for a new `what` ("session", "trial") of `whose` when the
    next one is `next_number`: used before (`used_on`, when it was), or past the next."""
    if used_on is not None:
        when = (f"started {used_on.astimezone():%d %b %Y %H:%M}"
                if isinstance(used_on, datetime.datetime) else f"on {used_on}")
        said = f"{whose} already has a {what} {number} ({when})"
    elif number > next_number:
        held = f"{what}s up to {next_number - 1} only" if next_number > 1 else f"no {what} yet"
        said = f"{whose} has {held}: {what} {number} would leave a gap"
    else:  # a gap left by a registry before v9: a new number still comes after the last
        said = (f"{whose}'s {what}s go up to {next_number - 1}: a new {what} takes the next "
                f"number, not {number}")
    return DuplicateNumberError(f"{said}; use {next_number}, the next free number{advice}")
