"""What an offline-capable station costs and how fast it catches up (issue 32;
app.records.station): on a throwaway PostgreSQL server (tests/postgres.py), one patient with
--trials trials already recorded, then

* the standby's rebuild after each write online (`mirror`: the patient's rows read from the
  server and a SQLite registry built from them), and a trial's begin + finish on the
  station against the same on a plain server `Registry`;
* offline: a trial's begin + finish answered by the standby;
* the sync of --offline trials recorded offline (one server transaction).

    .venv/bin/python bench/station_offline.py [--trials 300] [--offline 20] [--rounds 15]
"""

from __future__ import annotations

import argparse
import statistics
import sys
import tempfile
import time
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
if str(REPO) not in sys.path:  # tests.postgres and tests.netcut, when run as a file
    sys.path.insert(0, str(REPO))

from app.records.datadir import DataDir  # noqa: E402
from app.records.registry import Registry  # noqa: E402
from app.records.station import StationRegistry  # noqa: E402
from core.trial import THESIS_SUBJECT  # noqa: E402

METRICS = {f"metric_{i}": 1.0 + i for i in range(36)}  # a finished trial's ~36 figures


def _trial(registry, code: str) -> None:
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator")
    registry.finish_trial(begun.trial_id, "complete", METRICS)


def _times(work, rounds: int) -> list[float]:
    found = []
    for _ in range(rounds):
        start = time.perf_counter()
        work()
        found.append((time.perf_counter() - start) * 1e3)
    return found


def _line(name: str, ms: list[float]) -> None:
    print(f"  {name:<46} median {statistics.median(ms):7.1f} ms   max {max(ms):7.1f} ms")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=300)
    parser.add_argument("--offline", type=int, default=20)
    parser.add_argument("--rounds", type=int, default=15)
    args = parser.parse_args()
    from tests.netcut import NetworkCut
    from tests.postgres import start
    from tests.registries import ServerRegistries

    server = start()
    try:
        url = ServerRegistries(server).new()
        network = NetworkCut(url.port)
        with tempfile.TemporaryDirectory() as folder:
            # through the same relay as the station: a round trip costs the same to both
            plain = Registry(DataDir(Path(folder) / "plain"), server=network.url(url),
                             station="plain")
            code = plain.create_patient("Ada", "Example").code
            for _ in range(args.trials):
                _trial(plain, code)
            station = StationRegistry(DataDir(Path(folder) / "robot"), network.url(url),
                                      station="robot-1")
            station.patient(code)  # opened: mirrored
            print(f"one patient with {args.trials} trials on the server; "
                  f"rounds {args.rounds}")
            _line("mirror (the patient's rows -> standby)",
                  _times(station._mirror, args.rounds))
            _line("begin + finish, plain server Registry", _times(lambda: _trial(plain, code),
                                                                   args.rounds))
            _line("begin + finish, station online (+ 2 mirrors)",
                  _times(lambda: _trial(station, code), args.rounds))
            network.cut()
            _trial(station, code)  # finds the server gone
            _line("begin + finish, station offline", _times(lambda: _trial(station, code),
                                                            args.rounds))
            for _ in range(args.offline - args.rounds - 1):
                _trial(station, code)
            network.restore()
            start_s = time.perf_counter()
            synced = station.try_sync()
            took = time.perf_counter() - start_s
            print(f"  sync of {synced.trials} offline trials (one transaction, then a "
                  f"mirror): {took * 1e3:.0f} ms")
            station.close()
            network.cut()
    finally:
        server.stop()


if __name__ == "__main__":
    main()
