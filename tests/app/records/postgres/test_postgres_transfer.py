"""`rehab db upgrade --from FILE`: a console's SQLite registry moved onto the server, every
record kept (app.records.registry.transfer): read back through a station's login, the
server's registry says what the file said, and a station goes on numbering after it."""

from __future__ import annotations

import datetime
import sqlite3

import pytest
import sqlalchemy as sa

from app.plans.templates import load_template
from app.records.assistance import AssistanceInEffect
from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import THESIS_SUBJECT
from tests.app.cli.running import run
from tests.app.records.postgres.conftest import Registry as ServerRegistry

T0 = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=datetime.UTC)


def _a_clinics_registry(folder) -> Registry:
    """A registry with something in every table: names in several scripts, trials finished
    with metrics (NaN too) and levels, a proposal decided, a plan run with its steps, scales,
    notes, a trial marked invalid, a corrected measurement."""
    registry = Registry(DataDir(folder), station="robot-1")
    ada = registry.create_patient("Ada", "Lovelace-Ñúñez", birth_year=1950, side="left",
                                  body_mass_kg=61.5, sex="female", handedness="right").code
    bo = registry.create_patient("Bảo", "Nguyễn", notes="prefers mornings").code
    plan = registry.save_plan(ada, load_template("first-session").plan)
    run_id = registry.begin_plan_run(plan.id)
    ids = []
    for minutes, code in ((0, ada), (5, ada), (10, bo), (1440, ada)):
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                     patient_kind="weak", therapist="K. Lee",
                                     started_at=T0 + datetime.timedelta(minutes=minutes))
        ids.append(begun.trial_id)
        registry.finish_trial(begun.trial_id, "complete",
                              {"rmse_x_m": 0.0123456789, "sparc": float("nan")},
                              ended_at=T0 + datetime.timedelta(minutes=minutes + 1),
                              assistance=AssistanceInEffect(((0.0, 0.6), (2.0, 0.5))),
                              checksum="0f" * 32)
        registry.record_proposal(begun.trial_id, {"assistance_level": 0.5, "reason": "fine"})
    registry.record_plan_trial(run_id, 1, 1, ids[0], 60.0)
    registry.end_plan_run(run_id, "complete")
    registry.record_scale(ada, 1, "pain", total=3, rater="K. Lee")
    registry.add_note(ada, 1, "tired today — ça va", author="K. Lee", trial_id=ids[1])
    registry.mark_trial(ids[1], valid=False, reason="the cuff slipped", by="K. Lee")
    registry.correct_patient(ada, "body_mass_kg", 63.0, reason="weighed again", by="K. Lee")
    return registry


def _everything(registry: Registry) -> dict:
    patients = sorted(registry.patients(), key=lambda p: p.code)
    out = {"patients": patients}
    for patient in patients:
        code = patient.code
        out[code] = (registry.sessions(code), registry.trials_for_patient(code),
                     registry.trial_summaries(code, include_invalid=True),
                     registry.proposals_for_patient(code), registry.plans_for_patient(code),
                     registry.plan_runs_for_patient(code), registry.scale_entries(code),
                     registry.notes(code), registry.invalid_trials(code),
                     registry.corrections(code))
    return out


def test_a_registry_file_is_copied_onto_the_server_keeping_every_record(
        postgres_server, station, capsys, tmp_path):
    source = _a_clinics_registry(tmp_path / "clinic")
    server = ServerRegistry(postgres_server)
    with server.engine() as engine, engine.begin() as conn:  # made empty by its owner
        for table in ("corrections", "trial_marks", "notes", "scales", "plan_steps",
                      "plan_runs", "plans", "proposals", "trials", "sessions", "patients"):
            conn.execute(sa.text(f"DELETE FROM {table}"))
    station(server.url())
    code, out, err = run(["db", "upgrade", "--from", str(tmp_path / "clinic")], capsys)
    assert (code, err) == (0, "")
    assert "copied into it (patients 2, sessions 3, trials 4, proposals 4, plans 1" in out
    assert "every row's seal on the server is the file's" in out
    assert "nothing to do" not in out  # "…: nothing to do; the registry … copied into it"

    login = sa.make_url(server.url(server.clinic_login))
    moved = Registry(DataDir(tmp_path / "clinic"), server=login, station="robot-2")
    assert _everything(moved) == _everything(source)
    assert moved.integrity_check() == []
    ada = moved.patients()[0].code if moved.patients()[0].first_name == "Ada" else \
        moved.patients()[1].code
    after = moved.begin_trial(ada, THESIS_SUBJECT, backend="simulator")
    assert (after.session_number, after.trial_number) == (3, 1)  # a new day: the next
    assert after.trial_id == 5  # the ids go on after the copied ones


def test_a_copy_into_a_registry_holding_records_or_of_a_damaged_file_is_refused_whole(
        postgres_server, station, capsys, tmp_path):
    source = _a_clinics_registry(tmp_path / "clinic")
    server = ServerRegistry(postgres_server)
    login = sa.make_url(server.url(server.clinic_login))
    Registry(DataDir(tmp_path / "other"), server=login).create_patient("Cy", "Other")
    station(server.url())
    code, out, err = run(["db", "upgrade", "--from", str(source.path)], capsys)
    assert (code, out) == (2, "")
    assert "already holds records (patients 1): a registry file is copied only into an " \
           "empty one; nothing was copied" in err
    assert err.count("\n") == 1

    empty = ServerRegistry(postgres_server)
    station(empty.url())
    with sqlite3.connect(source.path) as conn:  # a flipped value, past the console
        conn.execute("DROP TRIGGER trials_sealed_on_update")
        conn.execute("UPDATE trials SET status = 'faulted' WHERE id = 2")
    code, out, err = run(["db", "upgrade", "--from", str(source.path)], capsys)
    assert (code, out) == (2, "")
    assert "trials row 2 does not match its seal" in err
    with empty.engine() as engine, engine.connect() as conn:
        assert conn.execute(sa.text("SELECT count(*) FROM patients")).scalar_one() == 0


def test_from_needs_a_server_and_a_registry_file(station, capsys, tmp_path):
    _a_clinics_registry(tmp_path / "clinic")
    code, out, err = run(["db", "upgrade", "--from", str(tmp_path / "clinic")], capsys)
    assert (code, out) == (2, "")
    assert "--from copies a SQLite registry onto a PostgreSQL server" in err


@pytest.mark.parametrize("given", ["", "nowhere"])
def test_from_without_a_registry_file_is_refused(postgres_server, station, capsys,
                                                 tmp_path, given):
    server = ServerRegistry(postgres_server)
    station(server.url())
    code, out, err = run(["db", "upgrade", "--from", given and str(tmp_path / given)], capsys)
    assert (code, out) == (2, "")
    assert ("--from is empty" in err) if not given else ("no registry file at" in err)
