"""bench/stations.py's checks after the stations have registered, and the server it ran
on: every patient's session numbers and every session's trial numbers 1..n without gaps or
repeats, every trial a station registered there once as handed out and finished, and every
row matching its seal (app.records.registry.postgres.seals.verify, what `rehab db status`
checks). Imported by bench/stations.py, which puts the repository on the path first.
"""

from __future__ import annotations

import time

import sqlalchemy as sa
from stations_fill import Bench

from app.records.registry.postgres.seals import verify as verify_server_seals


def check_numbers(bench: Bench, registered: list[tuple[int, str, int, int]]) -> list[str]:
    problems = []
    engine = sa.create_engine(bench.owner_url, poolclass=sa.NullPool)
    try:
        with engine.connect() as conn:
            bad_sessions = conn.execute(sa.text(
                "SELECT patient_id, count(*), count(DISTINCT number), max(number) "
                "FROM sessions GROUP BY patient_id "
                "HAVING count(*) <> count(DISTINCT number) OR max(number) <> count(*) "
                "OR min(number) <> 1")).all()
            bad_trials = conn.execute(sa.text(
                "SELECT session_id, count(*), count(DISTINCT number), max(number) "
                "FROM trials GROUP BY session_id "
                "HAVING count(*) <> count(DISTINCT number) OR max(number) <> count(*) "
                "OR min(number) <> 1")).all()
            problems += [f"patient {r[0]}: {r[1]} sessions, {r[2]} numbers, highest {r[3]}"
                         for r in bad_sessions]
            problems += [f"session {r[0]}: {r[1]} trials, {r[2]} numbers, highest {r[3]}"
                         for r in bad_trials]
            ids = [r[0] for r in registered]
            found = conn.execute(sa.text(
                "SELECT t.id, p.code, s.number, t.number, t.status FROM trials t "
                "JOIN sessions s ON s.id = t.session_id JOIN patients p ON p.id = s.patient_id "
                "WHERE t.id = ANY(:ids)"), {"ids": ids}).all()
            stored = {r[0]: (r[0], r[1], r[2], r[3]) for r in found}
            if len(set(ids)) != len(ids):
                problems.append(f"{len(ids) - len(set(ids))} trial ids handed out twice")
            wrong = [r for r in registered if stored.get(r[0]) != r]
            if wrong:
                problems.append(f"{len(wrong)} registered trials not stored as handed out, "
                                f"e.g. {wrong[0]}")
            unfinished = sum(1 for r in found if r[4] != "complete")
            if unfinished:
                problems.append(f"{unfinished} registered trials not finished")
    finally:
        engine.dispose()
    return problems


def verify_seals(bench: Bench) -> tuple[float, str]:
    engine = sa.create_engine(bench.owner_url, poolclass=sa.NullPool)
    t0 = time.perf_counter()
    try:
        with engine.connect() as conn:
            verify_server_seals(conn, bench.database)
        verdict = "every row matches its seal"
    except Exception as exc:  # printed: the bench goes on
        verdict = f"FAILED: {exc}"
    finally:
        engine.dispose()
    return time.perf_counter() - t0, verdict


def server_settings(bench: Bench) -> str:
    engine = sa.create_engine(bench.owner_url, poolclass=sa.NullPool)
    try:
        with engine.connect() as conn:
            version = conn.execute(sa.text("SHOW server_version")).scalar_one()
            buffers = conn.execute(sa.text("SHOW shared_buffers")).scalar_one()
            fsync = conn.execute(sa.text("SHOW fsync")).scalar_one()
    finally:
        engine.dispose()
    return f"PostgreSQL {version}, shared_buffers {buffers}, fsync {fsync}"
