"""Where a study runs: a local Dask cluster, or a scheduler someone runs for a cluster.

The local cluster is two worker processes of one thread each
(`distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True)`): processes,
because h5py is not thread-safe and the analysis is Python and numpy that one process runs
on one core; one thread each, so a worker never reads two trial files at once. Everything
it opens listens on 127.0.0.1 only, and it has no dashboard: a researcher's laptop on a
hospital network offers nothing to the network, and the tests never talk off the machine.

A scheduler's address (`tcp://host:8786`, or `host:8786`) joins a cluster a department
runs (`dask scheduler` on one machine, `dask worker tcp://host:8786` on each of the
others); its workers must see the trial files at the same paths (a shared folder).

Every refusal is one line saying what is wrong and what to do (AppError). Waiting is
patient: on a shared machine a worker process may take long to start, and a slow start is
not a failure (no short deadline here).
"""

from __future__ import annotations

import contextlib
import logging
import math
from collections.abc import Iterator

from app.errors import AppError
from device.safewrite import folded, shown

LOCAL_HOST = "127.0.0.1"
LOCAL_WORKERS = 2
SCHEMES = ("tcp", "tls", "ws", "wss")
CONNECT_TIMEOUT_S = 30.0
"""How long to try to reach a scheduler given by address before saying it cannot be."""
MAX_CONNECT_TIMEOUT_S = 600.0
SCHEDULER_HTTP = {"dashboard": False, "dashboard_address": f"{LOCAL_HOST}:0"}
"""The scheduler's own HTTP server (its health check; the dashboard stays off): on
127.0.0.1 at a port the system gives, not 8787, which another study or a test running
meanwhile may hold (Dask would warn and take another)."""
# silence_logs: a worker's heartbeat that meets the scheduler closing at the end logs an
# error with its traceback; what fails in a study is its files', listed with why
QUIET_WORKERS = {"distributed.worker.profile.enabled": False}
"""A local worker does not profile its tasks: Dask's profiler samples the working thread's
stack every 10 ms by default, taking the interpreter from the analysis each time."""
PRELOAD = ["app.study.rows"]
"""What a local worker imports as it starts (the reader, the analysis, scipy: seconds),
rather than in its first task: a study's time is then the files'."""
LOCAL_PATIENCE_S = 600.0
"""How long the local cluster's own processes may take to start and answer: they are on
this machine, so only a stalled machine is slow, and a stall is waited out."""


class _QuietShutdown(logging.Filter):
    """Drops the nanny's 'Worker process still alive after 4.0 seconds, killing' of a local
    worker stopped at the end: the study's results are written by then, and on a busy
    machine a worker that takes longer than Dask's 4 s to exit is killed, which costs
    nothing. Said as a warning after a study that succeeded, it made a newcomer think
    something had failed."""

    def filter(self, record: logging.LogRecord) -> bool:
        return not record.getMessage().startswith("Worker process still alive after")



def scheduler_address(text: str) -> str:
    """The scheduler's address as Dask takes it (`tcp://host:port`), from what was typed
    (`host:port` means tcp); AppError saying what is wrong otherwise."""
    from distributed.comm.addressing import parse_address, parse_host_port

    typed = text.strip()
    hint = ("give the scheduler's address as tcp://HOST:PORT (e.g. tcp://10.0.0.5:8786, "
            "as `dask scheduler` prints it), or leave --scheduler out for a local cluster")
    if not typed or any(c.isspace() for c in typed):
        raise AppError(f"--scheduler {shown(text)!r} is not an address: {hint}")
    address = typed if "://" in typed else f"tcp://{typed}"
    try:
        scheme, location = parse_address(address, strict=True)
        host, port = parse_host_port(location)
    except (ValueError, TypeError) as exc:
        raise AppError(f"--scheduler {shown(text)!r} is not an address ({folded(exc)}): "
                       f"{hint}") from None
    if scheme not in SCHEMES:
        raise AppError(f"--scheduler {shown(text)!r}: Dask does not speak {scheme!r}; {hint}")
    if not host or not isinstance(port, int) or not 1 <= port <= 65535:
        raise AppError(f"--scheduler {shown(text)!r} has no host or no port from 1 to "
                       f"65535: {hint}")
    return address


@contextlib.contextmanager
def study_client(scheduler: str | None = None, *, workers: int = LOCAL_WORKERS,
                 connect_timeout_s: float = CONNECT_TIMEOUT_S) -> Iterator:
    """A `distributed.Client`: to a local cluster of `workers` processes (scheduler None),
    or to the scheduler at that address; closed (and the local cluster stopped) on
    leaving."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is None:
        if isinstance(workers, bool) or not isinstance(workers, int) or workers < 1:
            raise AppError(f"workers = {workers!r}: give a whole number of worker processes "
                           "from 1")
        patience = f"{int(LOCAL_PATIENCE_S)}s"
        with dask.config.set({"distributed.comm.timeouts.connect": patience,
                              "distributed.comm.timeouts.tcp": patience,
                              "distributed.deploy.lost-worker-timeout": patience,
                              **QUIET_WORKERS}), contextlib.ExitStack() as stack:
            # first in, last out: still there while the cluster stops
            # each cluster its own filter: one shared by two clusters (a study run while
            # another is open) was taken away as the first one stopped
            nanny, quiet = logging.getLogger("distributed.nanny"), _QuietShutdown()
            nanny.addFilter(quiet)
            stack.callback(nanny.removeFilter, quiet)
            try:
                cluster = stack.enter_context(LocalCluster(
                    n_workers=workers, threads_per_worker=1, processes=True,
                    host=LOCAL_HOST, dashboard_address=None, worker_dashboard_address=None,
                    silence_logs=logging.CRITICAL, scheduler_kwargs=SCHEDULER_HTTP,
                    preload=PRELOAD))
                client = stack.enter_context(Client(cluster, timeout=patience))
            except (OSError, RuntimeError, TimeoutError) as exc:
                raise AppError(f"the local Dask cluster did not start ({folded(exc)}): check "
                               "the free memory and that this machine can start processes "
                               "and listen on 127.0.0.1, or give --scheduler") from None
            yield client
        return
    address = scheduler_address(scheduler)
    if not (isinstance(connect_timeout_s, int | float) and math.isfinite(connect_timeout_s)
            and 0 < connect_timeout_s <= MAX_CONNECT_TIMEOUT_S):
        raise AppError(f"--connect-timeout {connect_timeout_s!r}: give a number of seconds "
                       f"above 0 and at most {MAX_CONNECT_TIMEOUT_S:g}")
    _answers_as_a_scheduler(address, connect_timeout_s)
    try:
        client = Client(address, timeout=f"{connect_timeout_s}s")
    except (OSError, TimeoutError, ValueError) as exc:
        raise AppError(f"cannot reach the Dask scheduler at {address} ({folded(exc)}): check "
                       "the address and that the scheduler runs (`dask scheduler` prints "
                       "its address), or leave --scheduler out for a local cluster") \
            from None
    with client:
        yield client


def _answers_as_a_scheduler(address: str, timeout_s: float) -> None:
    """Dask's own handshake with `address`, within `timeout_s` as a whole, before a Client
    is made: Dask bounds the connection but not the handshake's answer, so a service that
    accepts and stays silent (a web server, a firewall's proxy) held `rehab study analyse`
    for ever, and one that speaks first (SSH) had its greeting read as a frame's length and
    said 'the input is too large to hold in memory'. AppError in one line for each."""
    import asyncio

    from distributed import Security
    from distributed.comm import CommClosedError, connect

    hint = ("check the address and that the scheduler runs (`dask scheduler` prints its "
            "address), or leave --scheduler out for a local cluster")

    async def handshake() -> None:
        arguments = Security().get_connection_args("client")
        comm = await asyncio.wait_for(connect(address, timeout=timeout_s, **arguments),
                                      timeout_s)
        await comm.close()

    try:
        asyncio.run(handshake())
    except TimeoutError:  # (an OSError: first)
        # Dask retries a refused connection until its own timeout, the same as this wait's:
        # which ends first is the machine's timing, so whether the port takes a connection
        # at all is asked once more (a refused port read as a silent service under load)
        refused = _refused(address, timeout_s)
        if refused:
            raise AppError(f"cannot reach the Dask scheduler at {address} ({refused}): "
                           f"{hint}") from None
        raise AppError(f"{address} took the connection but did not answer as a Dask "
                       f"scheduler within {timeout_s:g} s (another service on that port?): "
                       f"{hint}") from None
    except (OSError, CommClosedError) as exc:  # refused, no such host, closed on us
        raise AppError(f"cannot reach the Dask scheduler at {address} ({folded(exc)}): "
                       f"{hint}") from None
    except TypeError as exc:  # Dask: TLS without a context
        if "ssl_context" not in str(exc):
            raise
        raise AppError(f"{address} asks for TLS, and Dask's configuration has no "
                       "certificates for it (distributed.comm.tls: ca-file, client cert and "
                       "key): set them, or give the scheduler's tcp:// address") from None
    except Exception:  # what it sent is no Dask handshake (its bytes read as a length)
        raise AppError(f"{address} answered, but not as a Dask scheduler (another service "
                       f"on that port?): {hint}") from None


def _refused(address: str, timeout_s: float) -> str:
    """'' when `address`'s host takes a TCP connection on its port, else why not."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        host, port = parse_host_port(parse_address(address)[1])
        socket.create_connection((host, port), timeout=timeout_s).close()
    except (OSError, ValueError) as exc:
        return folded(exc)
    return ""


def worker_count(client) -> int:
    """The workers the client's scheduler has now (at least 1, for the chunking)."""
    return max(1, len(client.scheduler_info(n_workers=-1).get("workers", {})))
