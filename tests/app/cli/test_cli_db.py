"""`rehab db status` and `rehab db upgrade` on SQLite: the data folder's registry (no URL
file) or one a private URL file names. Each refusal is one line with exit code 2. (On a
PostgreSQL server: tests/app/records/postgres/test_postgres_db_cli.py.)"""

from __future__ import annotations

import contextlib
import sqlite3

from app.records.registry import SCHEMA_VERSION, seals
from tests.app.cli.running import run, status_names_the_unsealed_row
from tests.app.records.test_registry import make_v1_registry


def add_patient(capsys) -> str:
    code, out, _ = run(["patients", "add", "--first-name", "Ada"], capsys)
    assert code == 0
    return out.strip()


def sql(path, *statements) -> None:
    with contextlib.closing(seals.register(sqlite3.connect(path, isolation_level=None))) as conn:
        for statement in statements:
            conn.execute(statement)


def test_status_of_the_data_folders_registry(data, capsys):
    add_patient(capsys)
    code, out, err = run(["db", "status"], capsys)
    assert (code, err) == (0, "")
    lines = out.splitlines()
    assert lines[0].startswith(f"registry: SQLite file {data / 'registry.sqlite3'} (from the "
                               "data folder given by the environment; no registry URL file at ")
    assert lines[1:] == [
        f"schema: v{SCHEMA_VERSION} here, this console v{SCHEMA_VERSION}: up to date",
        "rows: patients 1, sessions 0, trials 0, proposals 0, plans 0, plan_runs 0, "
        "plan_steps 0, scales 0, notes 0, trial_marks 0, corrections 0",
        "seals: every row matches its seal (and SQLite's integrity check passes)"]


def test_status_changes_nothing_and_refuses_a_missing_registry(data, capsys):
    code, out, err = run(["db", "status"], capsys)
    assert (code, out) == (2, "")
    assert err.startswith(f"rehab db status: error: no registry at {data / 'registry.sqlite3'}")
    assert err.count("\n") == 1
    assert not data.exists()


def test_upgrade_brings_an_old_registry_to_this_consoles_schema_keeping_a_copy(data, capsys):
    make_v1_registry(data)
    code, out, _ = run(["db", "status"], capsys)
    assert code == 0
    assert f"schema: v1 here, this console v{SCHEMA_VERSION}: an upgrade is due (`rehab db " \
        "upgrade`)" in out
    assert "seals: none before schema v6 (the upgrade seals every row)" in out
    code, out, err = run(["db", "upgrade"], capsys)
    assert (code, err) == (0, "")
    path = data / "registry.sqlite3"
    copy = next(data.glob("registry.sqlite3.v1-*.bak"))
    assert out == (f"the registry {path} upgraded from schema v1 to v{SCHEMA_VERSION}; its copy "
                   f"at v1 is kept as {copy.name}\n")
    code, out, _ = run(["db", "status"], capsys)
    assert code == 0
    assert "up to date" in out
    assert "rows: patients 1, sessions 1, trials 1," in out
    assert "seals: every row matches its seal" in out
    code, out, _ = run(["db", "upgrade"], capsys)
    assert (code, out) == (0, f"the registry {path} is at schema v{SCHEMA_VERSION}, this "
                              "console's: nothing to do\n")


def test_a_registry_newer_than_the_console_is_refused_in_one_line(data, capsys):
    add_patient(capsys)
    path = data / "registry.sqlite3"
    sql(path, f"PRAGMA user_version = {SCHEMA_VERSION + 1}")
    code, out, err = run(["db", "upgrade"], capsys)
    assert (code, out) == (2, "")
    assert err == (f"rehab db upgrade: error: the registry {path} has schema "
                   f"v{SCHEMA_VERSION + 1}, written by a newer console; this one reads up to "
                   f"v{SCHEMA_VERSION}. Update the console\n")
    code, out, _ = run(["db", "status"], capsys)
    assert code == 0
    assert (f"schema: v{SCHEMA_VERSION + 1} here, this console v{SCHEMA_VERSION}: the registry "
            "is newer, update this console (an upgrade is refused)") in out
    assert "seals: not checked (the registry is newer than this console)" in out


def test_status_says_which_row_does_not_match_its_seal(data, capsys):
    add_patient(capsys)
    sql(data / "registry.sqlite3", "UPDATE patients SET seal = 'forged'")
    status_names_the_unsealed_row(capsys)


def test_a_sqlite_url_file_names_the_registry(data, tmp_path, capsys):
    add_patient(capsys)
    (data / "registry.sqlite3").rename(tmp_path / "moved.sqlite3")
    config = tmp_path / "config"
    config.mkdir(mode=0o700, exist_ok=True)
    url = config / "registry.url"
    url.write_text(f"sqlite:///{tmp_path / 'moved.sqlite3'}\n")
    url.chmod(0o600)
    code, out, _ = run(["db", "status"], capsys)
    assert code == 0
    assert out.startswith(f"registry: SQLite file {tmp_path / 'moved.sqlite3'} (from the URL "
                          f"file {url})")
    assert "rows: patients 1," in out


def test_a_url_file_others_can_read_refuses_both_commands_in_one_line(data, tmp_path, capsys):
    config = tmp_path / "config"
    config.mkdir(mode=0o700)
    url = config / "registry.url"
    url.write_text("postgresql://station:pw@127.0.0.1/rehab\n")
    url.chmod(0o644)
    for action in ("status", "upgrade"):
        code, out, err = run(["db", action], capsys)
        assert (code, out) == (2, "")
        assert err == (f"rehab db {action}: error: the registry URL file {url} can be read or "
                       f"written by others (mode 644): run `chmod 600 {url}`; if others may "
                       "have read a password in it, change that password on the server\n")


def test_role_names_are_checked_before_anything_is_done(data, capsys):
    code, _, err = run(["db", "upgrade", "--clinic-role", "Robert'); DROP TABLE x"], capsys)
    assert code == 2
    assert err.startswith("rehab db upgrade: error: the clinic role's name ")
    code, _, err = run(["db", "upgrade", "--research-role", "rehab_clinic"], capsys)
    assert code == 2
    assert "the clinic and research roles are both 'rehab_clinic'" in err
