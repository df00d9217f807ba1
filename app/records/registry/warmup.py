"""A station's registry on the server made ready for its first trial when it connects,
without writing anything (issue 32: registration p99 < 10 ms with 8 stations writing;
docs/performance.md, "The shared registry on PostgreSQL").

Why: a station's first registration is its process's first and its server process's first.
The server process has not yet read the catalog of the tables, indexes, constraints and
triggers the registration touches, nor planned its statements; the station's SQLAlchemy and
psycopg have not yet run their code for them. With 8 stations starting at once on the 2-core
VM that first `begin_trial` took 48 ms p50 (the trials after it 4-7 ms), and it was the
whole p99 over the stations' trials (bench/stations.py prints it apart).

What `warm_up` does, in one read transaction of the pool's connection (REPEATABLE READ,
ended by ROLLBACK, as every read): it runs what `begin_trial` reads, with a patient that
cannot be (code '', id 0: no row matches, so the patient's row lock locks nothing), and
asks the server to plan, without running them, the writes a registration makes (`EXPLAIN`
without ANALYZE: the server parses and plans each statement, reading the catalog of the
tables it writes, their indexes, constraints and triggers, and executes nothing: no row is
written, no trigger fires, no identity number is taken). tests/app/records/postgres/
test_postgres_warmup.py holds that: SELECT and EXPLAIN only, every table and sequence as
it was.

What it cannot warm: the trigger functions (the seals', the numbering's, the proposal's
patient: PL/pgSQL compiled at a backend's first call) and the foreign keys' checks, which
only a write runs. A rolled-back write would warm them but takes an identity number, locks
the patient's row and leaves a dead row: not done. Measured at 10⁶ trials with 8 stations
(docs/performance.md): the first trial's p50 48.5 → 35 ms; one station alone 9.4 → 8.4-9.0
ms (its trials after, 3-4 ms). A registry on SQLite has nothing to warm (a connection per
call).
"""

from __future__ import annotations

from app.records.registry.database import Database
from app.records.registry.patients import PATIENT_LOCKED
from app.records.registry.proposals import DECIDE, RECORD, pending
from app.records.registry.sessions import INSERT_SESSION, sessions_for_a_trial
from app.records.registry.statements import execute
from app.records.registry.trials import FINISH_TRIAL, INSERT_TRIAL

NOBODY = 0
"""A patient, trial and session id no row has (the server's identities start at 1)."""

PLANNED = (
    (INSERT_SESSION, (NOBODY, 1, "2000-01-01", "", "", "")),
    (INSERT_TRIAL, (NOBODY, 1, "{}", "", "recording", "2000-01-01T00:00:00+00:00",
                    "", None, None)),
    (DECIDE, ("kept", NOBODY, "", NOBODY)),
    (FINISH_TRIAL, ("complete", "{}", "", "", None, None, None, NOBODY, "recording")),
    (RECORD, ("{}", "", NOBODY)),
)
"""The writes of a trial's registration (begin_trial's session, when it opens one, its
trial and the pending proposal's decision; finish_trial; record_proposal), with values of
their types, which the server plans and does not run."""


class Warmup(Database):
    """Warming a station's registry on the server (a part of Registry)."""

    def warm_up(self) -> None:
        """begin_trial's reads for nobody and the registration's writes planned, in one
        read transaction; nothing on SQLite, nor on a researcher's login (it writes
        nothing)."""
        if not self.on_server or self.research:
            return
        with self._read() as conn:
            execute(conn, PATIENT_LOCKED, ("",)).fetchall()
            sessions_for_a_trial(conn, NOBODY, None)
            pending(conn, NOBODY, NOBODY)
            for statement, values in PLANNED:
                execute(conn, "EXPLAIN " + statement, values).fetchall()
