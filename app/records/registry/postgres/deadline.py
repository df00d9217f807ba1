"""A station's connection to the server that waits a bounded time for each answer.

Why: a network that drops traffic without a word (a pulled cable, a switch that died, a
firewall that drops rather than refuses) ends nothing: the station's statement is sent,
the operating system keeps retransmitting it, and the driver waits for the answer for as
long as TCP takes to give up, about 15 minutes on Linux. The window registered a trial on
its own thread, so at a Start or a trial's end the console froze, the robot's loop missed
the window's heartbeat and faulted, and the session stopped: what issue 32 forbids ("a
station never stops a session because the network is down"). A refused connection, or a
server that went down, was always seen at once; only silence was not. (The window now
registers on its job thread, ui.window.start, and stays live through this bound.)

What: every wait for the server (a statement's answer, a commit's) gives up after
`ANSWER_TIMEOUT_S`. The connection is then closed, never used again (what it was doing
on the server is unknown; the server rolls back an open transaction when the connection
goes), and the call fails as a lost connection does: the registry reports the server
unreachable and the station records on its own (app.records.station) until it answers
again. psycopg's `Connection.wait` takes such a limit (psycopg 3.2+); the station's pool
makes its connections of this class (SQLAlchemy's `do_connect`). Making the connection has
its own limit, libpq's `connect_timeout` (app.records.registry.database.CONNECT_TIMEOUT_S).

Not for the owner's and administrator's commands (`rehab db upgrade`, whose migration may
run for minutes on a large registry), nor for a researcher's reads, which may rightly take
long: only a station's registry, whose every statement takes milliseconds
(docs/performance.md: registration p99 under 12 ms, the progress query under 60 ms, with 8
stations writing).
"""

from __future__ import annotations

import psycopg
from psycopg import errors

ANSWER_TIMEOUT_S = 5.0
"""How long a station waits for one answer of the server: a hundred times what the slowest
of its statements takes with 8 stations writing, and short of the point where a therapist
pressing Start would think the console hung."""


class StationConnection(psycopg.Connection):
    """psycopg's connection, each wait for the server bounded by ANSWER_TIMEOUT_S."""

    def wait(self, gen, interval=0.1, timeout=None):  # type: ignore[override]
        try:
            return super().wait(gen, interval=interval,
                                timeout=ANSWER_TIMEOUT_S if timeout is None else timeout)
        except errors._WaitTimeout:
            # the connection's state is unknown: closed, so the pool never hands it out
            self.pgconn.finish()
            raise psycopg.OperationalError(
                f"the server did not answer within {ANSWER_TIMEOUT_S:g} s (the network "
                "drops what is sent, or the server is stuck)") from None


def on_do_connect(dialect, connection_record, cargs, cparams):
    """SQLAlchemy's `do_connect` event: the station's connection, made as the dialect
    would make psycopg's own."""
    return StationConnection.connect(*cargs, **cparams)
