"""How the server stores a trial's row (app.records.registry.postgres.TRIALS_UNCOMPRESSED):
whole and uncompressed, so that the progress query does not decompress a patient's metrics
each time it reads them; set by `create_registry` and by `rehab db upgrade` on a registry
made before it, every record and read left as it was."""

from __future__ import annotations

import sqlalchemy as sa

from app.records.datadir import DataDir
from app.records.registry import SCHEMA_VERSION, Registry as Console
from app.records.registry.postgres import trials_uncompressed
from app.records.registry.postgres.tables import REGISTRY_TABLES
from app.records.registry.url import shown_url
from core.trial import TrialParameters
from tests.app.cli.running import run
from tests.app.records.postgres.conftest import Registry

# a trial's metrics as long as a real trial's (some 1,400 bytes of JSON): with its
# parameters the row is over the server's 2,032 bytes, where it compresses by default
METRICS = {f"metric_{i:02d}_of_the_trial": 0.123456789 * (i + 1) for i in range(48)}


def _compressions(registry: Registry) -> list[str | None]:
    """Each trial's metrics as the server stores them: its compression, None if none."""
    with registry.engine() as engine, engine.connect() as conn:
        return list(conn.execute(sa.text(
            "SELECT pg_column_compression(metrics) FROM trials ORDER BY id")).scalars())


def _rows(registry: Registry) -> dict[str, list]:
    with registry.engine() as engine, engine.connect() as conn:
        return {table: conn.execute(sa.text(f"SELECT * FROM {table} ORDER BY 1")).all()
                for table in REGISTRY_TABLES}


def _finished_trial(console: Console, code: str) -> None:
    begun = console.begin_trial(code, TrialParameters(), backend="simulator")
    console.finish_trial(begun.trial_id, "complete", METRICS)


def test_a_new_registry_stores_a_trials_row_uncompressed(postgres_server, tmp_path):
    registry = Registry(postgres_server)
    console = Console(DataDir(tmp_path / "data"),
                      server=sa.make_url(registry.url(registry.clinic_login)))
    code = console.create_patient("Ada", "Example").code
    _finished_trial(console, code)
    with registry.engine() as engine, engine.connect() as conn:
        assert trials_uncompressed(conn)
        assert conn.execute(sa.text("SELECT octet_length(t.*::text) FROM trials t")
                            ).scalar_one() > 2032  # over the default threshold
    assert _compressions(registry) == [None]
    assert console.trial_summaries(code)[0].metrics == METRICS


def test_upgrade_stores_the_trials_written_after_it_uncompressed_and_changes_no_record(
        postgres_server, station, capsys, tmp_path):
    """A registry of today's schema made before the setting: its trials compressed. `rehab
    db upgrade` sets it (one line saying so), every row stays as it was (its seal too) and
    reads the same; the trials written after are stored uncompressed; a second upgrade has
    nothing to do."""
    registry = Registry(postgres_server)
    registry.server.admin_sql("ALTER TABLE trials RESET (toast_tuple_target)",
                              database=registry.database)
    login = sa.make_url(registry.url(registry.clinic_login))
    console = Console(DataDir(tmp_path / "data"), server=login)
    code = console.create_patient("Ada", "Example").code
    for _ in range(3):
        _finished_trial(console, code)
    assert _compressions(registry) == ["pglz"] * 3
    before, summaries = _rows(registry), console.trial_summaries(code)
    station(registry.url())
    shown = shown_url(sa.make_url(registry.url()))
    status, out, err = run(["db", "upgrade"], capsys)
    assert (status, err) == (0, "")
    assert out == (f"the registry at {shown} is at schema v{SCHEMA_VERSION}, this console's; "
                   "its trials written from now on are stored uncompressed (a faster progress "
                   "query)\n")
    assert _rows(registry) == before
    assert console.trial_summaries(code) == summaries
    assert console.integrity_check() == []
    _finished_trial(console, code)
    assert _compressions(registry) == ["pglz"] * 3 + [None]
    assert console.trial_summaries(code)[:3] == summaries
    assert console.trial_summaries(code)[3].metrics == METRICS
    status, out, _ = run(["db", "upgrade"], capsys)
    assert (status, out) == (0, f"the registry at {shown} is at schema v{SCHEMA_VERSION}, "
                                "this console's: nothing to do\n")
