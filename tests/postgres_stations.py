"""Stations registering trials for one patient at once, each in a process of its own, on
the tests' PostgreSQL server (tests/app/records/postgres/test_postgres_numbering.py).

Importable by name so a spawned process can run `station` (spawn, not fork: the test
process may hold threads and connections a fork would copy)."""

from __future__ import annotations

import datetime

import sqlalchemy as sa

from app.records.registry.postgres.tables import sessions, trials
from tests.patience import HANG_S


def station(url: str, index: int, patient: int, session: int, count: int, explicit: bool,
            start, results) -> None:
    """Register `count` trials in `session` as fast as the server lets it, after every
    station is ready (`start`, a barrier); every fourth one also opens a new session with
    its first trial in one transaction, as begin_trial does. `explicit`: read the next
    number, then insert it, and try again when the server refuses it (as a console that
    numbers for itself would); otherwise let the server number (`RETURNING number`).
    Puts (trial numbers, new sessions' numbers, refusals) on `results`."""
    engine = sa.create_engine(url, poolclass=sa.NullPool)
    numbers: list[int] = []
    opened: list[int] = []
    refusals = 0
    today = datetime.date.today().isoformat()
    try:
        start.wait(HANG_S)
        for i in range(count):
            values = dict(session_id=session, parameters="{}", status="recording",
                          started_at=datetime.datetime.now(datetime.UTC).isoformat(),
                          file=f"trials/station{index}/{i}.h5", backend="simulator")
            if not explicit:
                with engine.begin() as conn:
                    numbers.append(conn.execute(sa.insert(trials).values(**values)
                                                .returning(trials.c.number)).scalar_one())
            else:
                while True:
                    with engine.begin() as conn:
                        guess = conn.execute(
                            sa.select(sa.func.coalesce(sa.func.max(trials.c.number), 0) + 1)
                            .where(trials.c.session_id == session)).scalar_one()
                    try:
                        with engine.begin() as conn:
                            conn.execute(sa.insert(trials).values(number=guess, **values))
                    except sa.exc.IntegrityError:
                        refusals += 1
                        continue
                    numbers.append(guess)
                    break
            if i % 4 == 0:
                with engine.begin() as conn:
                    new_session, number = conn.execute(
                        sa.insert(sessions).values(patient_id=patient, date=today)
                        .returning(sessions.c.id, sessions.c.number)).one()
                    first = conn.execute(sa.insert(trials).values(
                        **values | dict(session_id=new_session,
                                        file=f"trials/station{index}/{i}-first.h5"))
                        .returning(trials.c.number)).scalar_one()
                    assert first == 1
                opened.append(number)
        results.put((index, numbers, opened, refusals, None))
    except BaseException as exc:
        results.put((index, numbers, opened, refusals, f"{type(exc).__name__}: {exc}"))
        raise
    finally:
        engine.dispose()
