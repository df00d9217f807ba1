"""The PostgreSQL registry seals each row with the digest the SQLite registry computes
(app.records.registry.postgres.seals against app.records.registry.seals): a row written on
both engines has the same seal, the server seals every row it stores whatever the client
sends, and a row changed behind the triggers' back is found."""

from __future__ import annotations

import contextlib
import itertools
import math

import pytest
import sqlalchemy as sa
from hypothesis import given, strategies as st

from app.errors import SchemaError
from app.records.registry import seals as sqlite_seals
from app.records.registry.postgres import seals
from app.records.registry.postgres.tables import metadata, patients
from tests.app.records.postgres.test_postgres_tables import sqlite_registry

# PostgreSQL's text holds neither NUL nor a lone surrogate (the server refuses them)
TEXT = st.text(st.characters(blacklist_categories=("Cs",), blacklist_characters="\x00"),
               max_size=40)
NUMBER = st.floats(allow_nan=False)  # SQLite stores NaN as NULL; PostgreSQL refuses it


@pytest.fixture(scope="module")
def engines(registry):
    """The module's SQLite registry in memory and a connection to its PostgreSQL one."""
    with contextlib.closing(sqlite_registry()) as lite, registry.engine() as engine, \
            engine.connect() as server:
        server.commit()
        yield lite, server


def _insert_both(engines, table: str, values: dict) -> tuple[str, str]:
    """Insert the row on both engines; their seals."""
    lite, server = engines
    names = ", ".join(values)
    marks = ", ".join("?" for _ in values)
    lite.execute(f"INSERT INTO {table} ({names}) VALUES ({marks})", tuple(values.values()))
    where = " AND ".join(f"{name} = ?" for name in _key(table))
    lite_seal = lite.execute(f"SELECT seal FROM {table} WHERE {where}",
                             tuple(values[name] for name in _key(table))).fetchone()[0]
    t = metadata.tables[table]
    server_seal = server.execute(sa.insert(t).values(**values).returning(t.c.seal)).scalar_one()
    server.commit()
    return lite_seal, server_seal


def _key(table: str) -> list[str]:
    return [c.name for c in metadata.tables[table].primary_key.columns]


@given(st.floats(allow_nan=False) | st.sampled_from([5e-324, -5e-324, 2.2250738585072014e-308,
                                                     1.7976931348623157e308, -0.0]))
def test_the_servers_float_text_is_pythons_float_hex(engines, value):
    _, server = engines
    text = server.execute(sa.text("SELECT registry_float_hex(CAST(:v AS float8))"),
                          {"v": value}).scalar_one()
    assert text == (0.0 if value == 0 else value).hex()


_ids = itertools.count(1)


@given(first_name=st.none() | TEXT, last_name=st.none() | TEXT,
       birth_year=st.none() | st.integers(-2**63, 2**63 - 1),
       side=st.sampled_from([None, "right", "left"]),
       numbers=st.lists(st.none() | NUMBER, min_size=5, max_size=5),
       notes=TEXT, created_at=TEXT, sex=st.sampled_from([None, "female", "male"]),
       handedness=st.sampled_from([None, "right", "left"]))
def test_a_patient_written_on_both_engines_has_the_same_seal(
        engines, first_name, last_name, birth_year, side, numbers, notes, created_at, sex,
        handedness):
    row_id = next(_ids)
    values = dict(id=row_id, code=f"P{row_id:04d}", first_name=first_name,
                  last_name=last_name, birth_year=birth_year, side=side,
                  **dict(zip(("body_mass_kg", "upper_arm_m", "forearm_m", "shoulder_x_m",
                              "shoulder_y_m"), numbers, strict=True)),
                  notes=notes, created_at=created_at, sex=sex, handedness=handedness)
    lite_seal, server_seal = _insert_both(engines, "patients", values)
    assert server_seal == lite_seal
    # and it is the digest of the values SQLite reads back (-0.0 reads back as 0.0)
    stored = [0.0 if isinstance(v, float) and v == 0 else v
              for v in (values[c] for c in sqlite_seals.SEALED["patients"])]
    assert lite_seal == sqlite_seals.seal_of("patients", *stored)


SEALED_ROWS = [
    ("patients", dict(id=900_001, code="SEALS1", first_name="Zoë", last_name="Ñúñez",
                      birth_year=1950, side="left", body_mass_kg=71.25, upper_arm_m=0.3,
                      forearm_m=None, shoulder_x_m=-0.1, shoulder_y_m=1e-300,
                      notes="née «Ω»", created_at="2026-12-04T05:00:00.000000+00:00",
                      sex="female", handedness="right")),
    ("sessions", dict(id=900_001, patient_id=900_001, number=1, date="2026-12-04",
                      therapist="T. Ø", notes="", location="room 2")),
    ("trials", dict(id=900_001, session_id=900_001, number=1, parameters='{"a": 1.5}',
                    file="trials/SEALS1/t1.h5", metrics="{}", status="complete",
                    started_at="s", ended_at="e", patient_kind=None, backend="simulator",
                    end_reason="", assistance='{"start": 0.5}')),
    ("trials", dict(id=900_002, session_id=900_001, number=2, parameters="{}",
                    file="trials/SEALS1/t2.h5", metrics="{}", status="recording",
                    started_at="s", ended_at=None, patient_kind="weak", backend="sim",
                    end_reason="", assistance=None)),
    ("proposals", dict(trial_id=900_001, proposal="{}", decision="accepted",
                       next_trial_id=900_002, proposed_at="p", decided_at="d")),
    ("plans", dict(id=900_001, patient_id=900_001, name="plan", plan="{}", template="",
                   based_on=None, created_at="c")),
    ("plan_runs", dict(id=900_001, plan_id=900_001, started_at="s", ended_at=None,
                       status="running", end_reason="")),
    ("plan_steps", dict(run_id=900_001, step=1, block=1, round=1, kind="trial",
                        trial_id=900_001, planned_s=30.0, taken_s=29.875)),
    ("plan_steps", dict(run_id=900_001, step=2, block=1, round=1, kind="rest",
                        trial_id=None, planned_s=10.0, taken_s=None)),
    ("scales", dict(id=900_001, session_id=900_001, scale="ashworth", total=None,
                    detail='{"elbow": "1+"}', rater="R", recorded_at="r")),
    ("scales", dict(id=900_002, session_id=900_001, scale="fugl_meyer", total=42,
                    detail="{}", rater="R", recorded_at="r")),
    ("notes", dict(id=900_001, session_id=900_001, trial_id=900_001, text="tired",
                   author="A", written_at="w")),
    ("trial_marks", dict(id=900_001, trial_id=900_002, valid=0, reason="cough",
                         marked_by="M", marked_at="m")),
    ("corrections", dict(id=900_001, patient_id=900_001, field="body_mass_kg",
                         old_value="70.0", new_value="71.25", reason="scale",
                         corrected_by="C", corrected_at="c")),
]
"""One row of each sealed table, of every type its columns hold (ids 900_001…)."""


@pytest.fixture(scope="module")
def sealed_rows(engines):
    """SEALED_ROWS inserted on both engines, once for the module: each table's two seals."""
    return [(table, *_insert_both(engines, table, values)) for table, values in SEALED_ROWS]


def test_every_sealed_table_seals_a_row_as_sqlite_does(sealed_rows):
    """One row of each sealed table, of every type its columns hold, on both engines."""
    assert {table for table, *_ in sealed_rows} == set(sqlite_seals.SEALED)
    for table, lite_seal, server_seal in sealed_rows:
        assert server_seal == lite_seal, table


@pytest.mark.parametrize("table", sqlite_seals.SEALED)
def test_each_seal_is_one_expression_the_server_plans_once_per_session(registry, table):
    """The seal's parts (text, integer, real) are inlined where a seal is computed, so a seal
    trigger runs an expression its session planned once, instead of calling each part,
    whose body the server parsed and planned again in every transaction: 0.30 ms of a
    trial's registration per sealed row before (seals.FUNCTIONS, schema v12)."""
    with registry.engine() as engine, engine.connect() as conn:
        plan = "\n".join(conn.execute(sa.text(
            f"EXPLAIN VERBOSE SELECT public.{seals.seal_function(metadata.tables[table])}(r) "
            f"FROM {table} r")).scalars())
    assert "sha256(" in plan
    assert "registry_seal_text" not in plan
    assert "registry_seal_integer" not in plan
    assert "registry_seal_real" not in plan


def test_the_server_seals_every_row_whatever_the_client_sends(engines):
    _, server = engines
    server.execute(sa.insert(patients).values(id=900_100, code="FORGE", created_at="c",
                                              seal="forged"))
    server.execute(sa.update(patients).where(patients.c.id == 900_100)
                   .values(first_name="Ann", seal="forged again"))
    seal = server.execute(sa.select(patients.c.seal).where(patients.c.id == 900_100)
                          ).scalar_one()
    server.commit()
    values = [None] * len(sqlite_seals.SEALED["patients"])
    row = dict(zip(sqlite_seals.SEALED["patients"], values, strict=True)) | dict(
        id=900_100, code="FORGE", first_name="Ann", notes="", created_at="c")
    assert seal == sqlite_seals.seal_of("patients", *row.values())
    seals.verify(server, "the test registry")


def test_a_row_changed_behind_the_triggers_back_is_found(registry):
    with registry.engine() as engine, engine.begin() as conn:
        conn.execute(sa.insert(patients).values(id=900_200, code="BEHIND", first_name="Ann",
                                                created_at="c"))
        seals.verify(conn, "the test registry")
        # what a superuser can do: replication mode runs no ordinary trigger
        conn.execute(sa.text("SET LOCAL session_replication_role = replica"))
        conn.execute(sa.update(patients).where(patients.c.id == 900_200).values(first_name="Bob"))
        with pytest.raises(SchemaError, match=r"patients row 900200 does not match its seal"):
            seals.verify(conn, "the test registry")
        conn.rollback()


@pytest.mark.parametrize("table", ["scales", "notes", "trial_marks", "corrections"])
def test_what_a_therapist_recorded_is_kept_as_written(engines, sealed_rows, table):
    _, server = engines
    t = metadata.tables[table]
    # the row is there (sealed_rows), or an UPDATE and a DELETE of nothing pass untouched
    assert server.execute(sa.select(t.c.id).where(t.c.id == 900_001)).scalar_one() == 900_001
    server.rollback()
    for statement in (sa.update(t).where(t.c.id == 900_001).values(id=900_001),
                      sa.delete(t).where(t.c.id == 900_001)):
        with pytest.raises(sa.exc.IntegrityError, match=f"{table} are kept as written"):
            server.execute(statement)
        server.rollback()


def test_a_number_column_refuses_nan(engines):
    _, server = engines
    with pytest.raises(sa.exc.IntegrityError, match="body_mass_kg_is_a_number"):
        server.execute(sa.insert(patients).values(code="NAN", created_at="c",
                                                  body_mass_kg=math.nan))
    server.rollback()
