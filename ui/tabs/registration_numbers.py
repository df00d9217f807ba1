"""What the Registration tab shows of a patient's numbers, read from the registry in one go
(ui.tabs.registration.RegistrationTab.refresh_numbers).

Why apart: after each trial the window reads them on its job thread (ui/window/trial.py)
and shows them when read. On a station whose network went silent each read may wait the
registry's bounded wait (app.records.registry.postgres.deadline, 5 s) before the station
answers from its standby; read on the window's thread, they froze it that long.
"""

from __future__ import annotations

import dataclasses

from app.errors import RegistryError, SessionNotFound
from app.records.registry import Registration, Session, Trial
from app.records.registry.numbering import refuse_number
from app.records.store import RecordStore
from core.errors import capitalised
from ui.tabs.clinical_record import trial_items


@dataclasses.dataclass(frozen=True)
class Numbers:
    """The registry's numbers for patient `code`: the suggestion, their sessions by number,
    the suggested session's trials by number (or the registry's refusal to read them), the
    next free trial number of that session when the suggested one is used, and the
    clinical record's trial list (`record`: its patient's code, session and items; None
    when the record shows nobody)."""

    code: str
    suggestion: Registration
    sessions: dict[int, Session]
    used: dict[int, Trial] | RegistryError
    free: int
    record: tuple[str, int, list[tuple[str, int]]] | None


def gap_refusal(code: str, session: int, trial: int, used: dict[int, Trial],
                sessions: dict[int, Session]) -> str:
    """Why Start would refuse numbers whose trial is not used yet ('' when it would not):
    a new session past the patient's next, or a trial past its session's next (numbering
    is gap-free: app.records.registry.numbering), in the registry's own words. Confirm
    took session 2 of a patient with none, and only Start said "session 2 would leave a
    gap" (found by the window's state machine)."""
    if session in sessions:
        next_trial = max(used, default=0) + 1
    else:
        next_session = max(sessions, default=0) + 1
        if session != next_session:
            return capitalised(str(refuse_number("session", session, next_session,
                                                 whose=f"patient {code}", used_on=None)))
        next_trial = 1
    if trial != next_trial:
        return capitalised(str(refuse_number("trial", trial, next_trial,
                                             whose=f"patient {code} session {session}",
                                             used_on=None)))
    return ""


def read_numbers(registry: RecordStore, code: str,
                 record: tuple[str, int] | None) -> Numbers:
    """`Numbers` of patient `code` as the registry has them now; `record` is the clinical
    record's (patient code, session) whose finished trials are listed with them."""
    suggestion = registry.suggest_registration(code)
    session, trial = suggestion.session_number, suggestion.trial_number
    sessions = {s.number: s for s in registry.sessions(code)}
    used = session_trials(registry, code, session)
    free = registry.next_trial_number(code, session) \
        if isinstance(used, dict) and trial in used else trial
    items = None if record is None else (*record, trial_items(registry, *record))
    return Numbers(code, suggestion, sessions, used, free, items)


def session_trials(registry: RecordStore, code: str,
                   session: int) -> dict[int, Trial] | RegistryError:
    """The trials of patient `code`'s session by number (none for a session not begun), or
    the registry's refusal to read them."""
    try:
        return {t.number: t for t in registry.trials(code, session)}
    except SessionNotFound:
        return {}
    except RegistryError as exc:
        return exc


def read_choice(registry: RecordStore, code: str) -> Numbers | Exception:
    """What choosing patient `code` shows, read in one go on the window's job thread: their
    `Numbers`, with the clinical record's trials of the suggested session; or what the
    registry said instead (shown in one line, nothing shown as the patient's)."""
    try:
        numbers = read_numbers(registry, code, None)
        session = numbers.suggestion.session_number
        return dataclasses.replace(
            numbers, record=(code, session, trial_items(registry, code, session)))
    except Exception as exc:  # RegistryError, a station's fault: said, never raised here
        return exc


def sessions_read(registry: RecordStore, code: str) -> dict[int, Session] | Exception:
    """Patient `code`'s sessions by number, read on the window's job thread, or what the
    registry said instead (never raised there)."""
    try:
        return {s.number: s for s in registry.sessions(code)}
    except Exception as exc:  # RegistryError, a station's fault
        return exc
