"""A station's new connection to the server warmed up by a registration it rolls back
(app.records.registry.postgres.warm): it fires what a registration fires, leaves nothing
behind (no row, no id used up, no number taken), is not done for a research login or a
registry not at today's schema, and a warm-up that cannot run is logged and changes
nothing else."""

from __future__ import annotations

import logging

import psycopg
import pytest
import sqlalchemy as sa

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.records.registry.postgres import warm
from app.records.registry.postgres.tables import REGISTRY_TABLES
from core.trial import TrialParameters

PARAMS = TrialParameters()
SEQUENCES = ("patients", "sessions", "trials")


def _connect(url: sa.URL) -> psycopg.Connection:
    return psycopg.connect(host=url.host, port=url.port, user=url.username,
                           password=url.password, dbname=url.database, autocommit=True)


def _owner(postgres_server, url: sa.URL) -> sa.Engine:
    return sa.create_engine(postgres_server.url(database=url.database), poolclass=sa.NullPool)


def _state(engine: sa.Engine) -> dict[str, object]:
    """Every registry table's row count and each identity's last value, as the owner reads
    them."""
    with engine.connect() as conn:
        counts = {t: conn.exec_driver_sql(f"SELECT count(*) FROM {t}").scalar_one()
                  for t in REGISTRY_TABLES}
        ids = {t: conn.exec_driver_sql(
            f"SELECT last_value, is_called FROM {t}_id_seq").one() for t in SEQUENCES}
    return {"rows": counts, "ids": ids}


@pytest.fixture
def spy(monkeypatch) -> list[bool]:
    """What each warm-up of the pool's connections returned."""
    done: list[bool] = []
    real = warm.warm_up

    def counted(connection) -> bool:
        done.append(real(connection))
        return done[-1]

    monkeypatch.setattr(warm, "warm_up", counted)
    return done


def test_a_warm_up_fires_the_registrations_triggers_and_leaves_nothing(
        server_registries, postgres_server, tmp_path):
    url = server_registries.new()
    station = Registry(DataDir(tmp_path / "data"), server=url)
    code = station.create_patient("Ada", "Warm").code
    first = station.begin_trial(code, PARAMS, backend="simulator")
    station.finish_trial(first.trial_id, "complete", {})
    owner = _owner(postgres_server, url)
    try:
        before = _state(owner)
        with _connect(url) as conn:  # the station's login, as the pool connects it
            assert warm.warm_up(conn)
            assert warm.warm_up(conn)  # again on the same connection: its own rows again
            assert conn.info.transaction_status == psycopg.pq.TransactionStatus.IDLE
        assert _state(owner) == before
        # the next registration numbers and ids on as if no warm-up had been
        second = station.begin_trial(code, PARAMS, backend="simulator")
        assert (second.session_number, second.trial_number) == (1, 2)
        assert second.trial_id == first.trial_id + 1
    finally:
        owner.dispose()


def test_each_new_connection_of_a_station_is_warmed_up_not_a_researchers(
        server_registries, tmp_path, spy, caplog):
    url = server_registries.new()
    station = Registry(DataDir(tmp_path / "data"), server=url)
    code = station.create_patient("Ada", "Warm").code
    assert spy == [True]  # the pool's first connection, before the patient's insert
    station._writer.pool.dispose()  # a server restart, say: the next call connects anew
    station.begin_trial(code, PARAMS, backend="simulator")
    assert spy == [True, True]
    research = Registry(DataDir(tmp_path / "research"),
                        server=server_registries.as_researcher(url))
    assert len(research.trial_summaries(code)) == 1
    research._writer.pool.dispose()
    assert len(research.trial_summaries(code)) == 1
    assert spy == [True, True, False]  # its first connection, which says it is research's
    assert [r for r in caplog.records if r.name == warm.log.name] == []


def test_a_registry_not_at_todays_schema_is_left_alone(postgres_server, caplog):
    empty = postgres_server.create_database()  # before `rehab db upgrade` made it
    with _connect(sa.make_url(postgres_server.url(database=empty))) as conn, \
            caplog.at_level(logging.WARNING):
        assert not warm.warm_up(conn)
        with conn.cursor() as cursor:  # nothing was made, and the connection works
            cursor.execute("SELECT count(*) FROM pg_tables WHERE schemaname = 'public'")
            assert cursor.fetchone() == (0,)
    assert caplog.records == []


def test_a_warm_up_refused_by_the_server_is_logged_and_the_station_registers(
        server_registries, postgres_server, tmp_path, caplog, spy):
    url = server_registries.new()
    station = Registry(DataDir(tmp_path / "data"), server=url)
    code = station.create_patient("Ada", "Warm").code
    # a department whose stations may not add patients (its therapists do, elsewhere)
    postgres_server.admin_sql(f"REVOKE INSERT ON patients FROM {server_registries.roles.clinic}",
                              database=url.database)
    station._writer.pool.dispose()
    with caplog.at_level(logging.WARNING, logger=warm.log.name):
        begun = station.begin_trial(code, PARAMS, backend="simulator")
    assert spy == [True, False]
    assert begun.trial_number == 1
    message, = (r.getMessage() for r in caplog.records if r.name == warm.log.name)
    assert "not warmed up (InsufficientPrivilege: permission denied for table patients)" \
        in message


def test_a_servers_trigger_that_does_not_do_its_part_is_logged(
        server_registries, postgres_server, caplog):
    url = server_registries.new()
    postgres_server.admin_sql("ALTER TABLE trials DISABLE TRIGGER zz_trials_sealed",
                              database=url.database)
    with _connect(url) as conn, caplog.at_level(logging.WARNING, logger=warm.log.name):
        assert not warm.warm_up(conn)
    message, = (r.getMessage() for r in caplog.records)
    assert "the server gave its trial number 1 and no seal" in message
