"""Session and trial numbers unique and gap-free per patient, enforced by the server
(app.records.registry.postgres.numbering), with several stations registering trials for
one patient at once, each in a process of its own."""

from __future__ import annotations

import multiprocessing

import pytest
import sqlalchemy as sa

from app.records.registry.postgres import seals
from app.records.registry.postgres.tables import patients, sessions, trials
from tests.patience import HANG_S
from tests.postgres_stations import station

STATIONS = 4
TRIALS_EACH = 12


def _patient(conn, code: str) -> tuple[int, int]:
    """A new patient and their first session: (patient id, session id)."""
    patient = conn.execute(sa.insert(patients).values(code=code, created_at="c")
                           .returning(patients.c.id)).scalar_one()
    session = conn.execute(sa.insert(sessions).values(patient_id=patient, date="d")
                           .returning(sessions.c.id)).scalar_one()
    return patient, session


def _trial(session: int, file: str, number: int | None = None):
    values = dict(session_id=session, parameters="{}", status="recording", started_at="s",
                  file=file)
    if number is not None:
        values["number"] = number
    return sa.insert(trials).values(**values).returning(trials.c.number)


def test_the_server_numbers_and_refuses_a_gap_or_a_repeat(registry):
    with registry.engine(registry.clinic_login) as engine:
        with engine.begin() as conn:
            _, session = _patient(conn, "N001")
            assert conn.execute(_trial(session, "a")).scalar_one() == 1
            assert conn.execute(_trial(session, "b", 2)).scalar_one() == 2
        for number, words in ((2, "trial number 2 is not the next one"),
                              (4, "trial number 4 is not the next one"),
                              (0, "trial number 0 is not the next one")):
            with engine.begin() as conn, pytest.raises(sa.exc.IntegrityError, match=words) \
                    as refused:
                conn.execute(_trial(session, f"x{number}", number))
            assert "use 3" in str(refused.value)


def test_a_number_is_kept_and_only_the_last_trial_is_taken_back(registry):
    with registry.engine(registry.clinic_login) as engine:
        with engine.begin() as conn:
            patient, session = _patient(conn, "N002")
            for file in ("N002/a", "N002/b", "N002/c"):
                conn.execute(_trial(session, file))
        refusals = (
            (sa.update(trials).where(trials.c.file == "N002/c").values(number=9),
             "numbers are kept as given"),
            (sa.update(sessions).where(sessions.c.id == session).values(number=5),
             "numbers are kept as given"),
            (sa.delete(trials).where(trials.c.file == "N002/b"), "trial 2 cannot be taken back"),
        )
        for statement, words in refusals:
            with engine.begin() as conn, pytest.raises(sa.exc.IntegrityError, match=words):
                conn.execute(statement)
        with engine.begin() as conn:
            conn.execute(sa.delete(trials).where(trials.c.file == "N002/c"))  # the last one goes
            assert conn.execute(_trial(session, "N002/d")).scalar_one() == 3
            conn.execute(sa.update(sessions).where(sessions.c.id == session)
                         .values(therapist="T"))  # the rest of a session may change
        with engine.connect() as conn:
            assert conn.execute(sa.select(trials.c.number).where(trials.c.session_id == session)
                                .order_by(trials.c.number)).scalars().all() == [1, 2, 3]
            assert conn.execute(sa.select(sessions.c.number)
                                .where(sessions.c.patient_id == patient)).scalars().all() == [1]


def test_stations_registering_for_one_patient_at_once_lose_and_repeat_nothing(registry):
    """Four processes register trials for one patient at once, two letting the server
    number, two numbering for themselves and retrying when refused; each also opens new
    sessions. Every trial is registered once, and the numbers are 1..N without a gap."""
    with registry.engine() as engine, engine.begin() as conn:
        patient, session = _patient(conn, "N003")
    context = multiprocessing.get_context("spawn")
    start = context.Barrier(STATIONS)
    results = context.Queue()
    url = registry.url(registry.clinic_login)
    processes = [context.Process(target=station, args=(url, index, patient, session,
                                                       TRIALS_EACH, index % 2 == 1, start,
                                                       results))
                 for index in range(STATIONS)]
    for process in processes:
        process.start()
    try:
        reports = [results.get(timeout=HANG_S * 2) for _ in processes]
    finally:
        for process in processes:
            process.join(HANG_S)
            if process.is_alive():
                process.kill()
    failures = [f"station {index}: {error}" for index, *_, error in reports if error]
    assert not failures, failures
    assert [process.exitcode for process in processes] == [0] * STATIONS
    numbers = sorted(n for _, got, *_ in reports for n in got)
    opened = sorted(n for _, _, got, *_ in reports for n in got)
    assert numbers == list(range(1, STATIONS * TRIALS_EACH + 1))
    assert opened == list(range(2, len(opened) + 2))
    with registry.engine() as engine, engine.connect() as conn:
        stored = conn.execute(sa.select(trials.c.number).where(trials.c.session_id == session)
                              .order_by(trials.c.number)).scalars().all()
        assert stored == numbers
        assert conn.execute(sa.select(sessions.c.number).where(sessions.c.patient_id == patient)
                            .order_by(sessions.c.number)).scalars().all() == [1, *opened]
        firsts = conn.execute(
            sa.select(sa.func.count()).select_from(trials).join(sessions)
            .where(sessions.c.patient_id == patient, sessions.c.number > 1,
                   trials.c.number == 1)).scalar_one()
        assert firsts == len(opened)
        seals.verify(conn, "the test registry")  # each row sealed with the number it got
