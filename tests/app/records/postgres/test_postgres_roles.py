"""The clinic and research roles, enforced by the server (app.records.registry.postgres.
roles): the tests log in as each and try. A researcher's login reads codes and data but
no name, by any query; the clinic's reads and writes names; a login of neither role
cannot even connect."""

from __future__ import annotations

import contextlib
import json

import psycopg
import pytest
import sqlalchemy as sa

from app.records.registry.postgres.roles import (
    HIDDEN_FROM_RESEARCH,
    WITHHELD,
    granted_to_research,
    research_columns,
    visible_to_research,
)
from app.records.registry.postgres.tables import REGISTRY_TABLES

CANARY = "Zaphodia"
"""A name, and words about the patient, that must never reach a researcher."""

STAFF = "Trillianne"
"""A staff member's name, and words typed by staff, that must never reach a researcher
either (data minimisation)."""


@pytest.fixture(scope="module")
def filled(registry):
    """A patient named CANARY with a session, a trial, notes and a corrected name, and
    STAFF's name and words in every column that holds a person's name or typed text,
    written by the clinic's login."""
    with registry.engine(registry.clinic_login) as engine, engine.begin() as conn:
        run = conn.exec_driver_sql
        patient = run("INSERT INTO patients (code, first_name, last_name, notes, birth_year, "
                      "body_mass_kg, created_at) VALUES ('RC001', %s, %s, %s, 1950, 70.5, "
                      "'c') RETURNING id",
                      (CANARY, CANARY + "son", f"{CANARY} prefers mornings")).scalar_one()
        session = run("INSERT INTO sessions (patient_id, number, date, notes, therapist, "
                      "location) VALUES (%s, 1, '2026-12-04', %s, %s, %s) RETURNING id",
                      (patient, f"{CANARY} came with her son", STAFF,
                       f"{STAFF}'s room")).scalar_one()
        trial = run("INSERT INTO trials (session_id, number, parameters, file, status, "
                    "started_at) VALUES (%s, 1, '{}', 'trials/RC001/t1.h5', 'complete', 's') "
                    "RETURNING id",
                    (session,)).scalar_one()
        run("INSERT INTO notes (session_id, trial_id, text, author, written_at) VALUES "
            "(%s, %s, %s, %s, 'w')", (session, trial, f"{CANARY} was tired", STAFF))
        run("INSERT INTO scales (session_id, scale, total, rater, recorded_at) VALUES "
            "(%s, 'pain', 3, %s, 'r')", (session, STAFF))
        run("INSERT INTO trial_marks (trial_id, valid, reason, marked_by, marked_at) VALUES "
            "(%s, 0, %s, %s, 'm')", (trial, f"{STAFF} saw her cough", STAFF))
        plan = {"name": f"{CANARY}'s mornings",
                "blocks": [{"shape": "d", "rounds": 2, "name": f"{STAFF}'s warm-up"},
                           {"shape": "o", "rounds": 1, "name": ""}]}
        run("INSERT INTO plans (patient_id, name, plan, created_at) VALUES (%s, %s, %s, "
            "'c')", (patient, plan["name"], json.dumps(plan)))
        run("UPDATE patients SET first_name = %s WHERE id = %s", (CANARY + "a", patient))
        run("INSERT INTO corrections (patient_id, field, old_value, new_value, reason, "
            "corrected_by, corrected_at) VALUES (%s, 'first_name', %s, %s, 'typo', 'C', "
            "'c'), (%s, 'body_mass_kg', '70.0', '70.5', 'scale', 'C', 'c')",
            (patient, f'"{CANARY}"', f'"{CANARY}a"', patient))
    return registry


def _connect(registry, login) -> psycopg.Connection:
    name, password = login
    return psycopg.connect(host="127.0.0.1", port=registry.server.port, user=name,
                           password=password, dbname=registry.database, autocommit=True)


@pytest.mark.parametrize("query", [
    "SELECT first_name FROM patients",
    "SELECT last_name FROM public.patients",
    "SELECT * FROM patients",
    "SELECT notes FROM patients",
    "SELECT seal FROM patients",
    "SELECT p FROM patients p",
    "SELECT registry_seal_of_patients(p) FROM patients p",
    "SELECT notes FROM sessions",
    "SELECT text FROM notes",
    "SELECT old_value FROM corrections",
    "SELECT count(*) FROM corrections",
    "SELECT seal FROM trials",
    "COPY patients (first_name) TO STDOUT",
])
def test_a_researchers_login_cannot_read_a_name_even_with_sql(filled, query):
    with _connect(filled, filled.research_login) as conn, \
            pytest.raises(psycopg.errors.InsufficientPrivilege, match="permission denied"):
        conn.execute(query)


@pytest.mark.parametrize(("table", "column"), [
    (table, column) for table, columns in HIDDEN_FROM_RESEARCH.items() for column in columns])
def test_no_hidden_column_reaches_a_researchers_login(filled, table, column):
    """Each column holding a name or typed text, tried by research in the table (refused
    by privilege) and in research's view (there, so the registry's reads run unchanged,
    and empty in every row)."""
    with _connect(filled, filled.research_login) as conn:
        with pytest.raises(psycopg.errors.InsufficientPrivilege, match="permission denied"):
            conn.execute(f"SELECT {column} FROM public.{table}")
        values = {v for (v,) in conn.execute(f"SELECT {column} FROM research.{table}")}
        assert values <= {"", WITHHELD}


def test_staff_names_are_hidden_from_research_too():
    """The lead's decision: no person's name, the staff's included, and no typed text."""
    hidden = {column for columns in HIDDEN_FROM_RESEARCH.values() for column in columns}
    assert {"therapist", "rater", "author", "marked_by", "corrected_by", "location",
            "reason", "text", "notes", "name"} <= hidden


def test_a_researcher_reads_a_plan_without_its_names(filled):
    with _connect(filled, filled.research_login) as conn:
        (text,) = conn.execute("SELECT plan FROM research.plans").fetchone()
        with pytest.raises(psycopg.errors.InsufficientPrivilege):
            conn.execute("SELECT plan FROM public.plans")
    assert json.loads(text) == {"blocks": [{"shape": "d", "rounds": 2},
                                           {"shape": "o", "rounds": 1}]}


@pytest.mark.parametrize("statement", [
    "INSERT INTO patients (code, created_at) VALUES ('X', 'c')",
    "UPDATE trials SET status = 'faulted'",
    "DELETE FROM trials",
    "CREATE TABLE research.mine (x int)",
    "CREATE TABLE public.mine (x int)",
])
def test_a_researchers_login_changes_nothing(filled, statement):
    with _connect(filled, filled.research_login) as conn, \
            pytest.raises(psycopg.errors.InsufficientPrivilege):
        conn.execute(statement)


def test_a_researchers_login_reads_codes_and_data(filled):
    with _connect(filled, filled.research_login) as conn:
        assert conn.execute("SELECT code, birth_year, body_mass_kg FROM patients").fetchall() \
            == [("RC001", 1950, 70.5)]
        assert conn.execute("SELECT p.code, t.status FROM research.patients p JOIN "
                            "research.sessions s ON s.patient_id = p.id JOIN research.trials t "
                            "ON t.session_id = s.id").fetchall() == [("RC001", "complete")]
        row = conn.execute("SELECT * FROM research.patients")
        assert [c.name for c in row.description] == list(research_columns("patients"))
        assert row.fetchone()[2:4] == ("", "")  # first and last name: there, empty
        assert conn.execute("SELECT field, old_value, new_value FROM research.corrections"
                            ).fetchall() == [("body_mass_kg", "70.0", "70.5")]


def test_everything_a_researcher_can_export_holds_no_name(filled):
    """Every view research has, every row as text: the canary appears nowhere (and the
    patient's code does, so the dump is not empty)."""
    with _connect(filled, filled.research_login) as conn:
        views = [name for (name,) in conn.execute(
            "SELECT table_name FROM information_schema.views WHERE table_schema = 'research'")]
        assert sorted(views) == sorted(REGISTRY_TABLES)
        dump = "\n".join(str(row) for view in views for row in conn.execute(
            f"SELECT row_to_json(v)::text FROM research.{view} v"))
        # and every column it may read from the tables themselves
        for table in REGISTRY_TABLES:
            columns = ", ".join(granted_to_research(table) or visible_to_research(table))
            with pytest.raises(psycopg.errors.InsufficientPrivilege) \
                    if not granted_to_research(table) else contextlib.nullcontext():
                dump += "\n".join(str(row) for row in conn.execute(
                    f"SELECT {columns} FROM public.{table}"))
    assert "RC001" in dump
    assert "warm" not in dump
    assert "mornings" not in dump
    assert CANARY not in dump
    assert STAFF not in dump
    assert set(HIDDEN_FROM_RESEARCH) <= set(REGISTRY_TABLES)


def test_the_planners_statistics_show_research_no_name(filled):
    """The planner's statistics keep a column's most common values (names among them):
    PostgreSQL shows research only those of the columns it may read. (A second patient of
    the same first name, for the time of the test, puts the name among the common values:
    the owner sees it there.)"""
    admin = filled.server.admin_sql
    admin(f"INSERT INTO patients (code, first_name, created_at) VALUES ('RC002', "
          f"'{CANARY}a', 'c')", "ANALYZE", database=filled.database)
    try:
        with _connect(filled, filled.research_login) as conn:
            shown = conn.execute("SELECT attname, most_common_vals::text FROM pg_stats "
                                 "WHERE tablename IN ('patients', 'sessions', 'notes', "
                                 "'corrections', 'scales', 'trial_marks', 'plans')").fetchall()
        with psycopg.connect(filled.url().replace("+psycopg", "")) as conn:
            assert CANARY in str(conn.execute(
                "SELECT most_common_vals::text FROM pg_stats WHERE tablename = 'patients' "
                "AND attname = 'first_name'").fetchall())
    finally:
        admin("DELETE FROM patients WHERE code = 'RC002'", "ANALYZE", database=filled.database)
    assert "code" in {name for name, _ in shown}
    assert not {"first_name", "last_name", "notes", "text", "old_value", "therapist"} & \
        {name for name, _ in shown}
    assert CANARY not in str(shown)
    assert STAFF not in str(shown)


def test_the_clinics_login_reads_and_writes_names(filled):
    with _connect(filled, filled.clinic_login) as conn:
        assert conn.execute("SELECT first_name FROM patients").fetchall() == [(CANARY + "a",)]
        assert conn.execute("SELECT count(*) FROM corrections").fetchone() == (2,)
        for statement in ("DELETE FROM patients", "DELETE FROM sessions",
                          "UPDATE notes SET author = 'X'"):
            with pytest.raises((psycopg.errors.InsufficientPrivilege,
                                psycopg.errors.IntegrityConstraintViolation)):
                conn.execute(statement)


def test_a_login_of_neither_role_cannot_connect(filled):
    outsider = filled.server.create_login("outsider")
    with pytest.raises(psycopg.OperationalError, match="permission denied for database"):
        _connect(filled, outsider).close()


def test_the_roles_are_the_servers_not_the_consoles_choice(filled):
    """Through SQLAlchemy as the console would: the research login's refusal is the
    server's error, not a check in Python."""
    with filled.engine(filled.research_login) as engine, engine.connect() as conn, \
            pytest.raises(sa.exc.ProgrammingError, match="permission denied for table patients"):
        conn.execute(sa.text("SELECT first_name FROM patients"))
