"""What a trial's registration costs on the wire to the server (issue 32: registration p99 <
10 ms with 8 stations on one server; bench/registration.py, docs/performance.md), and the
station's reconnection by itself after the server or the network was away, which the
pool's ping before every transaction gave and the transaction's own BEGIN gives now
(`Database._on_server`)."""

from __future__ import annotations

import contextlib
import tempfile

import sqlalchemy as sa
from psycopg import pq

from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import TrialParameters
from tests.netcut import NetworkCut

PARAMS = TrialParameters()


class Wire:
    """The round trips of a registry's connections to the server, read from libpq's trace
    of each connection (PQtrace): every exchange ends with the server's ReadyForQuery. The
    pool's connections are made anew, each traced from its start (the pool's ping, if any,
    comes before SQLAlchemy's checkout event), and the trace is flushed at each check-in."""

    def __init__(self, registry: Registry) -> None:
        self._file = tempfile.TemporaryFile()  # noqa: SIM115 (closed by close(), after the
        # connections that trace into it)
        self._engine = engine = registry._writer
        sa.event.listen(engine.pool, "connect", self._trace)
        sa.event.listen(engine.pool, "checkin", self._flushed)
        engine.pool.dispose()  # the connections made from now on are traced
        self.exchanges = 0

    def close(self) -> None:
        self._engine.dispose()  # the traced connections closed before their file
        self._file.close()

    def _trace(self, dbapi_connection, _record) -> None:
        dbapi_connection.pgconn.trace(self._file.fileno())
        dbapi_connection.pgconn.set_trace_flags(pq.Trace.SUPPRESS_TIMESTAMPS)

    def _flushed(self, dbapi_connection, _record) -> None:
        if dbapi_connection is not None and not dbapi_connection.closed:
            dbapi_connection.pgconn.untrace()  # flushes what libpq buffered
            self._trace(dbapi_connection, _record)

    def _ready(self) -> int:
        self._file.seek(0)
        return sum(1 for line in self._file if b"\tReadyForQuery\t" in line)

    @contextlib.contextmanager
    def counting(self):
        before = self._ready()
        yield self
        self.exchanges = self._ready() - before


def test_a_trials_registration_makes_one_round_trip_a_statement_and_none_more(
        server_registries, tmp_path):
    """Each call: BEGIN, its statements, COMMIT, each one exchange with the server. Before,
    the pool pinged every connection it handed out (`pool_pre_ping`), one more exchange a
    call: begin_trial 8, finish_trial and record_proposal 4 each; begin_trial 7 then, the
    pending proposal read apart from the sessions."""
    registry = Registry(DataDir(tmp_path / "data"), server=server_registries.new(),
                        station="robot-1")
    code = registry.create_patient("Ada", "Example").code
    first = registry.begin_trial(code, PARAMS, backend="simulator")
    registry.finish_trial(first.trial_id, "complete", {"rmse_x_m": 0.01})
    registry.record_proposal(first.trial_id, {"assistance_level": 0.5})
    wire = Wire(registry)
    try:
        registry.trial(first.trial_id)  # a connection in the pool, as a running station has
        with wire.counting():  # the lock, the sessions and the pending proposal, the insert,
            # the proposal's decision (before, the proposal's read apart: 7)
            begun = registry.begin_trial(code, PARAMS, backend="simulator")
        assert wire.exchanges == 6
        with wire.counting():
            registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.02})
        assert wire.exchanges == 3
        with wire.counting():
            registry.record_proposal(begun.trial_id, {"assistance_level": 0.4})
        assert wire.exchanges == 3
        with wire.counting():  # a read: BEGIN ISOLATION LEVEL REPEATABLE READ, ROLLBACK
            assert [t.number for t in registry.trials_for_patient(code)] == [1, 2]
        assert wire.exchanges == 4
    finally:
        wire.close()


def test_a_station_reconnects_by_itself_after_the_network_was_away(server_registries,
                                                                   tmp_path):
    """The pool's connections ended by a drop are replaced at the next call, whose
    transaction begins again on a new connection: the call succeeds, nothing twice."""
    url = server_registries.new()
    network = NetworkCut(url.port)
    try:
        registry = Registry(DataDir(tmp_path / "data"), server=network.url(url),
                            station="robot-1")
        code = registry.create_patient("Ada", "Example").code
        registry.begin_trial(code, PARAMS, backend="simulator")
        network.cut()  # every connection through it ends
        network.restore()
        second = registry.begin_trial(code, PARAMS, backend="simulator")  # a write
        assert second.trial_number == 2
        network.cut()
        network.restore()
        assert [t.number for t in registry.trials_for_patient(code)] == [1, 2]  # a read
    finally:
        network.cut()


def test_a_failed_write_leaves_no_transaction_open_on_its_connection(server_registries,
                                                                     tmp_path):
    """The driver is in autocommit and the registry sends BEGIN itself (`_on_server`): a
    write that fails half-way must still end its transaction before its connection goes
    back to the pool (SQLAlchemy calls the driver's rollback(), which psycopg sends while
    the server's transaction is open), or the next transaction on that connection would
    run inside the failed one and commit what it left."""
    from psycopg.pq import TransactionStatus

    registry = Registry(DataDir(tmp_path / "data"), server=server_registries.new(),
                        station="robot-1")
    code = registry.create_patient("Ada", "Rollback", side="right").code
    statuses = []
    sa.event.listen(registry._writer.pool, "checkin",
                    lambda dbapi, record: statuses.append(
                        None if dbapi is None else dbapi.info.transaction_status))
    with contextlib.suppress(RuntimeError), registry._write() as conn:
        conn.exec_driver_sql(
            "UPDATE patients SET notes = 'half-way' WHERE code = %(code)s", {"code": code})
        raise RuntimeError("the write fails after its first statement")
    assert statuses
    assert statuses[-1] == TransactionStatus.IDLE
    assert registry.patient(code).notes != "half-way"  # nothing of it kept
    # and the pool's next transaction on that connection commits only its own
    registry.correct_patient(code, "side", "left", reason="entered wrong", by="K. Lee")
    assert registry.patient(code).side == "left"
    assert registry.patient(code).notes != "half-way"
