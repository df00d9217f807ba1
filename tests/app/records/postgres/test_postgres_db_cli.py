"""`rehab db status` and `rehab db upgrade` on the tests' PostgreSQL server, pointed at by a
private registry URL file as a station is: the registry created in an empty database with
the superuser's login, a newer one refused, research's login shown what it may read, a
server that cannot be reached named in one line. (On SQLite: tests/app/cli/test_cli_db.py.)"""

from __future__ import annotations

import secrets

import pytest
import sqlalchemy as sa

from app.errors import RegistryError
from app.records.registry import SCHEMA_VERSION
from app.records.registry.postgres import trials_uncompressed
from app.records.registry.postgres.seals import PARTS_STABLE
from app.records.registry.postgres.tables import REGISTRY_TABLES
from app.records.registry.url import shown_url
from tests.app.cli.running import run, status_names_the_unsealed_row
from tests.app.records.postgres.conftest import Registry
from tests.postgres import HOST, free_port


@pytest.fixture
def roles(postgres_server):
    """Group roles of the test's own (roles are the server's, shared by its databases)."""
    tag = secrets.token_hex(4)
    names = (f"clinic_cli_{tag}", f"research_cli_{tag}")
    for name in names:
        postgres_server.forget_role(name)
    return names


def test_upgrade_creates_the_registry_in_an_empty_database(postgres_server, station, roles,
                                                            capsys):
    database = postgres_server.create_database()
    url = postgres_server.url(database=database)
    file = station(url)
    shown = shown_url(sa.make_url(url))
    code, out, err = run(["db", "status"], capsys)
    assert (code, err) == (0, "")
    assert out.splitlines() == [
        f"registry: PostgreSQL {_version(postgres_server)} at {shown} (from the URL file "
        f"{file}), login {postgres_server.admin}",
        f"schema: none here (this console v{SCHEMA_VERSION}): `rehab db upgrade` creates the "
        "registry",
        "rows: no registry tables",
        "seals: not checked (no registry here)"]
    clinic, research = roles
    code, out, err = run(["db", "upgrade", "--clinic-role", clinic, "--research-role",
                          research], capsys)
    assert (code, err) == (0, "")
    assert out == (f"the registry created at {shown}: schema v{SCHEMA_VERSION}, seals, "
                   f"numbering, roles {clinic} (names) and {research} (codes and data)\n")
    code, out, err = run(["db", "status"], capsys)
    assert (code, err) == (0, "")
    assert out.splitlines()[1:] == [
        f"schema: v{SCHEMA_VERSION} here, this console v{SCHEMA_VERSION}: up to date",
        "rows: " + ", ".join(f"{table} 0" for table in REGISTRY_TABLES),
        "seals: every row matches its seal"]
    assert postgres_server.password not in out
    code, out, _ = run(["db", "upgrade", "--clinic-role", clinic, "--research-role",
                        research], capsys)
    assert (code, out) == (0, f"the registry at {shown} is at schema v{SCHEMA_VERSION}, this "
                              "console's: nothing to do\n")


def _version(server) -> str:
    with sa.create_engine(server.url(), poolclass=sa.NullPool).connect() as conn:
        return conn.execute(sa.text("SHOW server_version")).scalar_one()


@pytest.fixture(scope="module")
def filled(postgres_server):
    """A registry of today's schema with a patient, as the clinic's login wrote it."""
    registry = Registry(postgres_server)
    with registry.engine(registry.clinic_login) as engine, engine.begin() as conn:
        conn.exec_driver_sql("INSERT INTO patients (code, first_name, created_at) VALUES "
                             "('RC001', 'Zaphodia', 'c')")
    return registry


def test_status_counts_the_rows_and_checks_their_seals(filled, station, capsys):
    station(filled.url())
    code, out, _ = run(["db", "status"], capsys)
    assert code == 0
    assert "rows: patients 1, sessions 0," in out
    assert "seals: every row matches its seal" in out


def test_research_is_shown_what_it_may_read_and_no_seal(filled, station, capsys):
    name, password = filled.research_login
    station(filled.url(filled.research_login))
    code, out, err = run(["db", "status"], capsys)
    assert (code, err) == (0, "")
    assert f"login {name}" in out
    assert "corrections not readable by this login" in out
    assert "patients 1" in out
    assert f"seals: not checked (the login {name} may not read them)" in out
    assert password not in out


def test_a_row_changed_behind_the_triggers_is_named(postgres_server, station, capsys):
    registry = Registry(postgres_server)
    registry.server.admin_sql("INSERT INTO patients (code, created_at) VALUES ('RC009', 'c')",
                              "SET session_replication_role = replica",
                              "UPDATE patients SET birth_year = 1900",
                              database=registry.database)
    station(registry.url())
    status_names_the_unsealed_row(capsys, "postgresql://")


def test_a_registry_newer_than_the_console_is_refused(postgres_server, station, capsys):
    registry = Registry(postgres_server)
    registry.server.admin_sql(f"UPDATE schema_version SET version = {SCHEMA_VERSION + 1}",
                              database=registry.database)
    station(registry.url())
    shown = shown_url(sa.make_url(registry.url()))
    code, out, err = run(["db", "upgrade"], capsys)
    assert (code, out) == (2, "")
    assert err == (f"rehab db upgrade: error: the registry at {shown} has schema "
                   f"v{SCHEMA_VERSION + 1}, written by a newer console; this one reads up to "
                   f"v{SCHEMA_VERSION}. Update the console; nothing was changed\n")
    code, out, _ = run(["db", "status"], capsys)
    assert code == 0
    assert "the registry is newer, update this console (an upgrade is refused)" in out


def test_a_login_that_may_not_create_tables_is_refused_in_one_line(postgres_server, station,
                                                                  capsys):
    database = postgres_server.create_database()
    name, password = postgres_server.create_login("plain")
    postgres_server.admin_sql(f'GRANT CONNECT ON DATABASE "{database}" TO {name}')
    station(postgres_server.url(name, password, database=database))
    code, out, err = run(["db", "upgrade"], capsys)
    assert (code, out) == (2, "")
    assert err.startswith(f"rehab db upgrade: error: the registry's server {HOST}:"
                          f"{postgres_server.port} refused (permission denied for schema "
                          "public")
    assert err.endswith("; nothing was changed\n")


@pytest.mark.parametrize("action", ["status", "upgrade"])
def test_a_server_that_cannot_be_reached_is_named_in_one_line(station, action, capsys):
    port = free_port()  # nothing listens there
    file = station(f"postgresql://station3:s3cret@{HOST}:{port}/rehab")
    code, out, err = run(["db", action], capsys)
    assert (code, out) == (2, "")
    assert err.startswith(f"rehab db {action}: error: cannot reach the registry's server "
                          f"{HOST}:{port} (")
    assert err.endswith("): check that the server runs and that this station's network "
                        f"reaches it, and the URL in the URL file {file}\n")
    assert err.count("\n") == 1
    assert "s3cret" not in err
    assert "Traceback" not in err


@pytest.mark.parametrize("wrong", ["password", "database", "role"])
@pytest.mark.parametrize("command", [["db", "status"], ["trials", "RC001"]])
def test_a_login_the_server_refuses_is_named_with_what_to_do(filled, station, wrong, command,
                                                            capsys):
    """The server answered: it is not the network. These said 'cannot reach the registry's
    server … check that the server runs and that this station's network reaches it'."""
    name, password = filled.clinic_login
    outsider = filled.server.create_login("neither")  # a login of neither group role
    login, database = {"password": ((name, "not-" + password), filled.database),
                       "database": ((name, password), "no_such_registry"),
                       "role": (outsider, filled.database)}[wrong]
    file = station(filled.server.url(*login, database=database))
    code, out, err = run(command, capsys)
    assert (code, out) == (2, "")
    assert err.count("\n") == 1
    assert login[1] not in err
    where = (f"the URL file {file}" if command[0] == "db"
             else "the registry URL (registry.url in the config folder)")
    server = f"{HOST}:{filled.server.port}"
    assert "cannot reach" not in err
    assert {"password": f"the registry's server {server} refused the login {name} with its "
                        "password (",
            "database": f"the registry's server {server} has no database no_such_registry (",
            "role": f"the login {login[0]} may not connect to the database {database} on "
                    f"{server} ("}[wrong] in err
    assert {"password": f"): correct the user or password in {where}, or have the "
                        f"registry's owner set it (ALTER ROLE {name} PASSWORD '…', or CREATE "
                        f"ROLE {name} LOGIN PASSWORD '…' IN ROLE rehab_clinic)",
            "database": f"): correct the database in {where}, or create it (createdb "
                        "--owner rehab_owner no_such_registry)",
            "role": f"): the registry's owner makes it a station's or a researcher's (GRANT "
                    f"rehab_clinic TO {login[0]}, or rehab_research)"}[wrong] in err


def test_the_readmes_recipe_an_owner_who_may_create_roles_creates_the_registry(
        postgres_server, station, roles, capsys):
    """README, "Several stations": the department's owner login is no superuser; it owns
    the database and may create roles (the clinic and research group roles), and gives
    each station and researcher their login."""
    owner, password = postgres_server.create_login("owner")
    postgres_server.admin_sql(f"ALTER ROLE {owner} CREATEROLE")
    database = postgres_server.create_database()
    postgres_server.admin_sql(f'ALTER DATABASE "{database}" OWNER TO {owner}')
    station(postgres_server.url(owner, password, database=database))
    clinic, research = roles
    code, out, err = run(["db", "upgrade", "--clinic-role", clinic, "--research-role",
                          research], capsys)
    assert (code, err) == (0, "")
    assert out.startswith("the registry created at ")
    engine = sa.create_engine(postgres_server.url(owner, password, database=database),
                              poolclass=sa.NullPool)
    with engine.begin() as conn:
        conn.exec_driver_sql(f"CREATE ROLE station_{clinic} LOGIN PASSWORD 'x' IN ROLE "
                             f"{clinic}")
    engine.dispose()
    postgres_server.forget_role(f"station_{clinic}")
    station(postgres_server.url(f"station_{clinic}", "x", database=database))
    code, out, err = run(["db", "status"], capsys)
    assert (code, err) == (0, "")
    assert f"login station_{clinic}" in out
    assert "seals: every row matches its seal" in out


def _v12_as_it_was(registry: Registry) -> list[str]:
    """What v13 changed on the server, undone (app.records.registry.postgres.MIGRATIONS[13]):
    proposals without their patient, sealed over v12's columns, the pending ones indexed by
    trial, research's view without the column."""
    from app.records.registry import seals as sqlite_seals
    from app.records.registry.postgres import seals as server_seals, tables
    from app.records.registry.postgres.roles import research_view

    with pytest.MonkeyPatch.context() as v12:  # the seal function as v12 had it
        v12.setitem(sqlite_seals.SEALED, "proposals", sqlite_seals.SEALED_AT_V12["proposals"])
        function = server_seals.table_statements(tables.metadata.tables["proposals"])[0]
    return ["DROP VIEW research.proposals", "DROP TRIGGER proposals_patient ON proposals",
            "DROP FUNCTION proposals_patient()",
            function.replace("CREATE FUNCTION", "CREATE OR REPLACE FUNCTION", 1),
            "ALTER TABLE proposals DROP COLUMN patient_id",
            "UPDATE proposals SET decision = decision",  # each row sealed as v12 sealed it
            "CREATE INDEX proposals_pending ON proposals (trial_id) WHERE decision = 'pending'",
            research_view("proposals", at=12),
            f"GRANT SELECT ON research.proposals TO {registry.roles.research}"]


def _as_at_v12(registry: Registry) -> None:
    registry.server.admin_sql(*_v12_as_it_was(registry), "UPDATE schema_version SET version = 12",
                              "ALTER TABLE trials RESET (toast_tuple_target)",  # before it too
                              database=registry.database)


V11_AS_IT_WAS = (
    "DROP INDEX proposals_pending", "DROP INDEX proposals_by_next_trial",
    *(statement.replace(" STABLE", " IMMUTABLE") for statement in PARTS_STABLE),
)
"""What v12 changed on the server, undone: its indexes, and the seal's parts as they were
declared (app.records.registry.postgres.MIGRATIONS[12])."""


def _as_at_v11(registry: Registry) -> None:
    registry.server.admin_sql(*_v12_as_it_was(registry), *V11_AS_IT_WAS,
                              "UPDATE schema_version SET version = 11",
                              database=registry.database)


def _as_at_v8(registry: Registry) -> None:
    """Today's registry on the server made as v8 left it: without v10's and v11's columns
    (their seal functions and research's views as they were) nor v9's grants to clinic, nor
    v12's indexes."""
    from app.records.registry import seals as sqlite_seals
    from app.records.registry.postgres import seals as server_seals, tables
    from app.records.registry.postgres.roles import visible_to_research

    added = {"trials": ("station", "checksum", "stored_in"), "plan_runs": ("station",)}
    statements = [*_v12_as_it_was(registry), *V11_AS_IT_WAS,
                  *(f"DROP VIEW research.{table}" for table in added)]
    for table, columns in added.items():
        statements.append(f"ALTER TABLE {table} " + ", ".join(f"DROP COLUMN {c}"
                                                             for c in columns))
        with pytest.MonkeyPatch.context() as v9:  # the seal function as v9 had it
            v9.setitem(sqlite_seals.SEALED, table, sqlite_seals.SEALED_AT_V9[table])
            statements.append(server_seals.table_statements(tables.metadata.tables[table])[0]
                              .replace("CREATE FUNCTION", "CREATE OR REPLACE FUNCTION", 1))
        kept = [c for c in visible_to_research(table) if c not in columns]
        statements += [f"CREATE VIEW research.{table} WITH (security_barrier) AS SELECT "
                       f"{', '.join(kept)} FROM public.{table}",
                       f"GRANT SELECT ON research.{table} TO {registry.roles.research}"]
    registry.server.admin_sql(
        *statements, "UPDATE schema_version SET version = 8",
        f"REVOKE DELETE ON plan_steps, proposals FROM {registry.roles.clinic}",
        database=registry.database)


def test_a_v8_registry_on_the_server_is_upgraded_and_a_station_can_then_withdraw(
        postgres_server, station, capsys, tmp_path):
    """v8, the server's first: its clinic role could not delete a withdrawn trial's plan step
    or proposals, its trials kept no station nor checksum. `rehab db upgrade` brings it to
    today's, and a station's login then can withdraw a trial and record both."""
    from app.plans.templates import load_template
    from app.records.datadir import DataDir
    from app.records.registry import Registry as Console
    from core.trial import TrialParameters

    registry = Registry(postgres_server)
    _as_at_v8(registry)
    login = sa.make_url(registry.url(registry.clinic_login))
    with pytest.raises(RegistryError, match=r"holds a registry of schema v8; .*`rehab db "
                                            "upgrade`"):
        Console(DataDir(tmp_path / "data"), server=login)
    station(registry.url())
    shown = shown_url(sa.make_url(registry.url()))
    code, out, err = run(["db", "upgrade"], capsys)
    assert (code, err) == (0, "")
    assert out == f"the registry at {shown} updated from schema v8 to v{SCHEMA_VERSION}\n"

    console = Console(DataDir(tmp_path / "data"), server=login, station="robot-2")
    code = console.create_patient("Ada", "Example").code
    plan = console.save_plan(code, load_template("first-session").plan)
    run_id = console.begin_plan_run(plan.id)
    begun = console.begin_trial(code, TrialParameters(), backend="simulator")
    console.record_plan_trial(run_id, 1, 1, begun.trial_id, 60.0)
    console.record_proposal(begun.trial_id, {"assistance_level": 0.5})
    console.withdraw_trial(begun.trial_id, "its file was never written")
    assert console.trials_for_patient(code) == []
    assert console.proposal(begun.trial_id) is None
    begun = console.begin_trial(code, TrialParameters(), backend="simulator")
    done = console.finish_trial(begun.trial_id, "complete", {}, checksum="ab" * 32)
    assert (done.station, done.checksum) == ("robot-2", "ab" * 32)
    assert console.plan_run(run_id).station == "robot-2"
    assert console.integrity_check() == []


def test_a_v12_registry_on_the_server_is_upgraded_keeping_every_record(
        postgres_server, station, capsys, tmp_path):
    """v13 gives each proposal its trial's patient, sealed, and indexes the pending ones by
    it: `rehab db upgrade` brings a v12 registry holding two patients' trials, proposals
    pending and decided and a validity mark to it; every row is as it was but the
    proposals' new column (their trial's patient) and seal, every seal matches, the
    registry's reads give the same, research reads the column, and a proposal recorded
    after names its patient."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry as Console
    from core.trial import TrialParameters

    registry = Registry(postgres_server)
    login = sa.make_url(registry.url(registry.clinic_login))
    console = Console(DataDir(tmp_path / "data"), server=login, station="robot-1")
    codes = [console.create_patient(name, "Example").code for name in ("Ada", "Bea")]
    for code in codes * 2:
        begun = console.begin_trial(code, TrialParameters(), backend="simulator")
        console.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
        console.record_proposal(begun.trial_id, {"assistance_level": 0.5})
    console.mark_trial(begun.trial_id, valid=False, reason="the arm slipped", by="Dr B")
    reads = [(console.trials_for_patient(code), console.proposals_for_patient(code),
              console.pending_proposal(code)) for code in codes]

    def rows(columns: str = "*") -> dict[str, list]:
        with registry.engine() as engine, engine.connect() as conn:
            return {table: conn.execute(sa.text(
                f"SELECT {columns if table == 'proposals' else '*'} FROM {table} "
                "ORDER BY 1")).all() for table in REGISTRY_TABLES}

    _as_at_v12(registry)
    v12_columns = "trial_id, proposal, decision, next_trial_id, proposed_at, decided_at"
    before = rows()
    station(registry.url())
    code_, out, err = run(["db", "upgrade"], capsys)
    assert (code_, err) == (0, "")
    shown = shown_url(sa.make_url(registry.url()))
    assert out == f"the registry at {shown} updated from schema v12 to v{SCHEMA_VERSION}\n"
    after = rows(v12_columns + ", seal")
    assert {t: r for t, r in after.items() if t != "proposals"} == \
        {t: r for t, r in before.items() if t != "proposals"}
    assert [r[:-1] for r in after["proposals"]] == [r[:-1] for r in before["proposals"]]
    with registry.engine() as engine, engine.connect() as conn:
        assert conn.execute(sa.text(
            "SELECT count(*) FROM proposals p JOIN trials t ON t.id = p.trial_id JOIN "
            "sessions s ON s.id = t.session_id WHERE p.patient_id = s.patient_id")
            ).scalar_one() == len(before["proposals"]) == 4
        indexes = set(conn.execute(sa.text(
            "SELECT indexname FROM pg_indexes WHERE tablename = 'proposals'")).scalars())
        assert trials_uncompressed(conn)  # set by the upgrade, whatever the version
    assert {"proposals_pending_by_patient", "proposals_by_next_trial"} <= indexes
    assert "proposals_pending" not in indexes
    console = Console(DataDir(tmp_path / "data"), server=login, station="robot-1")
    assert console.integrity_check() == []
    assert [(console.trials_for_patient(code), console.proposals_for_patient(code),
             console.pending_proposal(code)) for code in codes] == reads
    with registry.engine(registry.research_login) as engine, engine.connect() as conn:
        assert conn.execute(sa.text("SELECT count(patient_id) FROM research.proposals")
                            ).scalar_one() == 4
        assert conn.execute(sa.text("SELECT count(patient_id) FROM proposals")).scalar_one() == 4
    begun = console.begin_trial(codes[1], TrialParameters(), backend="simulator")
    console.record_proposal(begun.trial_id, {"assistance_level": 0.4})
    assert console.pending_proposal(codes[1]).trial_id == begun.trial_id
    assert console.integrity_check() == []


def test_a_v11_registry_on_the_server_is_upgraded_keeping_every_record_and_seal(
        postgres_server, station, capsys, tmp_path):
    """v12 adds indexes and makes the seal's parts inlinable: `rehab db upgrade` brings a
    v11 registry holding trials, proposals pending and decided, and a validity mark, to it;
    every row is as it was, with its seal, and the registry's reads give the same."""
    from app.records.datadir import DataDir
    from app.records.registry import Registry as Console
    from core.trial import TrialParameters

    registry = Registry(postgres_server)
    login = sa.make_url(registry.url(registry.clinic_login))
    console = Console(DataDir(tmp_path / "data"), server=login, station="robot-1")
    code = console.create_patient("Ada", "Example").code
    for _ in range(3):
        begun = console.begin_trial(code, TrialParameters(), backend="simulator")
        console.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
        console.record_proposal(begun.trial_id, {"assistance_level": 0.5})
    console.mark_trial(begun.trial_id, valid=False, reason="the arm slipped", by="Dr B")
    reads = (console.trials_for_patient(code), console.proposals_for_patient(code),
             console.pending_proposal(code))

    def rows() -> dict[str, list]:
        with registry.engine() as engine, engine.connect() as conn:
            return {table: conn.execute(sa.text(f"SELECT * FROM {table} ORDER BY 1")).all()
                    for table in REGISTRY_TABLES}

    before = rows()
    _as_at_v11(registry)
    station(registry.url())
    code_, out, err = run(["db", "upgrade"], capsys)
    assert (code_, err) == (0, "")
    shown = shown_url(sa.make_url(registry.url()))
    assert out == f"the registry at {shown} updated from schema v11 to v{SCHEMA_VERSION}\n"
    assert rows() == before
    console = Console(DataDir(tmp_path / "data"), server=login, station="robot-1")
    assert (console.trials_for_patient(code), console.proposals_for_patient(code),
            console.pending_proposal(code)) == reads
    with registry.engine() as engine, engine.connect() as conn:
        indexes = set(conn.execute(sa.text(
            "SELECT indexname FROM pg_indexes WHERE tablename = 'proposals'")).scalars())
        parts = set(conn.execute(sa.text(
            "SELECT provolatile FROM pg_proc WHERE proname IN ('registry_seal_text', "
            "'registry_seal_integer', 'registry_seal_real')")).scalars())
    assert {"proposals_pending_by_patient", "proposals_by_next_trial"} <= indexes
    assert parts == {"s"}
    assert console.integrity_check() == []
