"""A station's registry warmed when it connects (app.records.registry.warmup): only reads and
plans, nothing written, no trigger fired, no identity number taken; a clinic login's station
warms, a researcher's login and a SQLite registry have nothing to warm."""

from __future__ import annotations

import contextlib

import sqlalchemy as sa

from app.records.datadir import DataDir
from app.records.registry import Registry as Console
from core.trial import TrialParameters
from tests.app.records.postgres.conftest import Registry


@contextlib.contextmanager
def sent_by_every_engine():
    """The statements any engine of this process sends meanwhile (SQLAlchemy's class-level
    event: the console's engines are made inside the `with`)."""
    sent: list[str] = []

    def statement(conn, cursor, text, *_) -> None:
        sent.append(" ".join(text.split()))

    sa.event.listen(sa.engine.Engine, "before_cursor_execute", statement)
    try:
        yield sent
    finally:
        sa.event.remove(sa.engine.Engine, "before_cursor_execute", statement)


def _everything(registry: Registry) -> tuple:
    """Every row of every table, and every identity sequence's state, as the owner reads
    them."""
    with registry.engine() as engine, engine.connect() as conn:
        tables = conn.execute(sa.text(
            "SELECT tablename FROM pg_tables WHERE schemaname = 'public' ORDER BY 1")).scalars()
        rows = {table: conn.execute(sa.text(f"SELECT * FROM {table} ORDER BY 1")).all()
                for table in list(tables)}
        sequences = conn.execute(sa.text(
            "SELECT sequencename, last_value FROM pg_sequences ORDER BY 1")).all()
    return rows, sequences


def test_the_warm_up_reads_and_plans_and_writes_nothing(postgres_server, tmp_path):
    registry = Registry(postgres_server)
    login = sa.make_url(registry.url(registry.clinic_login))
    console = Console(DataDir(tmp_path / "data"), server=login, station="robot-1")
    code = console.create_patient("Ada", "Example").code
    begun = console.begin_trial(code, TrialParameters(), backend="simulator")
    console.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
    console.record_proposal(begun.trial_id, {"assistance_level": 0.5})
    before = _everything(registry)
    with sent_by_every_engine() as sent:
        console.warm_up()
    assert sent[0].startswith("BEGIN ISOLATION LEVEL REPEATABLE READ")
    assert all(s.startswith(("SELECT ", "EXPLAIN ")) for s in sent[1:]), sent
    planned = [s for s in sent if s.startswith("EXPLAIN ")]
    assert any("INSERT INTO trials" in s for s in planned)
    assert any("INSERT INTO proposals" in s for s in planned)
    assert _everything(registry) == before
    again = console.begin_trial(code, TrialParameters(), backend="simulator")
    assert (again.trial_id, again.trial_number) == (begun.trial_id + 1, 2)
    assert console.proposal(begun.trial_id).next_trial_id == again.trial_id
    assert console.integrity_check() == []


def test_a_station_warms_its_registry_when_it_connects(postgres_server, tmp_path):
    registry = Registry(postgres_server)
    with sent_by_every_engine() as sent:
        Console(DataDir(tmp_path / "clinic"),
                server=sa.make_url(registry.url(registry.clinic_login)))
    assert any(s.startswith("EXPLAIN INSERT INTO trials") for s in sent)
    with sent_by_every_engine() as sent:  # research writes nothing: nothing to warm
        Console(DataDir(tmp_path / "research"),
                server=sa.make_url(registry.url(registry.research_login)))
    assert sent
    assert not any(s.startswith("EXPLAIN ") for s in sent)
    file = Console(DataDir(tmp_path / "file"))
    with sent_by_every_engine() as sent:  # a file: a connection per call, nothing to warm
        file.warm_up()
    assert sent == []
