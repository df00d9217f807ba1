"""Faults injected into live trials on the simulator, with the real processes (issue 28):
for each, how soon it was seen and how much of the trial its file lost.

    .venv/bin/python bench/fault_injection.py [--repeat N] [--seed S] [--fault NAME …]

Each run starts the console of tests/device/live_console.py (the device link, a 20-
repetition D on the simulator) in a process group of its own, waits a random number of
the trial's ticks (0.6-3 s), injects the fault and reads the trial file back
(tests/device/livefaults.py). "seen" is the time from the injection to the loop's fault
(its own monotonic time, in the fault's event), or to the console hearing that the loop
died; "ticks" the same in the loop's ticks, where a fault latched. "lost" counts the
ticks the loop pushed for the trial that the file lacks. "told": what the console last
heard of the file's end, "closed" or "lost" (the file could not be finished; the window
then finishes the trial from what reached it), "—" when no console was left to hear.
The full disk is a 96 MiB tmpfs filled by another process where this machine lets us
mount one (root), else injected at the recorder's write calls; the table says which.

First, what the trial file's disk reserve costs (device/recording/trialfile/reserve.py): a
100 s trial written as the recorder writes it (125 records a batch, a flush every other
batch) with and without the reserve, each flush timed, and the bytes the close's reopen
adds.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from tests.device.livefaults import FAULTS, PERIOD_S, run_fault
from tests.device.smalldisk import SmallDisk


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--repeat", type=int, default=1, help="runs of each fault")
    parser.add_argument("--seed", type=int, default=0, help="the random ticks' seed")
    parser.add_argument("--fault", action="append", choices=FAULTS,
                        help="only these faults (default: all)")
    args = parser.parse_args(argv)
    faults = args.fault or FAULTS
    _reserve_figures()
    print(f"{'fault':18s} {'made':9s} {'seen (s)':>14s} {'ticks':>9s} {'lost':>11s} "
          f"{'status':15s} {'told':7s} cause")
    started = time.monotonic()
    for index, fault in enumerate(faults):
        outcomes = []
        for run in range(args.repeat):
            with tempfile.TemporaryDirectory(prefix="rehab-fault-") as folder:
                disk = SmallDisk(Path(folder), 96) if fault == "disk full" else None
                try:
                    outcomes.append(run_fault(fault, Path(folder),
                                              args.seed + 1000 * index + run, disk))
                finally:
                    if disk is not None:
                        disk.close()
        print(_row(fault, outcomes), flush=True)
    print(f"\n{len(faults) * args.repeat} runs in {time.monotonic() - started:.0f} s")
    return 0


def _reserve_figures() -> None:
    import os

    from core.trial import THESIS_SUBJECT
    from device.recording.record import RECORD_DTYPE
    from device.recording.trialfile import SubjectInfo, TrialFileWriter
    from device.recording.trialfile.reserve import RESERVE_BYTES

    params = THESIS_SUBJECT.replace(repetitions=20)
    with tempfile.TemporaryDirectory(prefix="rehab-reserve-") as folder:
        # with and without the reserve side by side, the flushes interleaved, so that the
        # machine's load weighs on both alike
        writers = {reserve: TrialFileWriter(
            Path(folder) / f"t{reserve}.h5", parameters=params,
            subject=SubjectInfo.from_parameters("PBENCH", params), robot={},
            backend="simulator", sample_period_s=PERIOD_S, reserve_bytes=reserve,
            min_free_bytes=0) for reserve in (RESERVE_BYTES, 0)}
        flushes = {reserve: [] for reserve in writers}
        records = np.zeros(125, RECORD_DTYPE)
        for batch in range(400):
            records["tick"] = np.arange(batch * 125, (batch + 1) * 125)
            order = list(writers) if batch % 4 == 1 else list(writers)[::-1]
            for reserve in order:
                writers[reserve].append(records)
                if batch % 2:  # the recorder's: a flush every 0.25 s (two batches)
                    started = time.perf_counter()
                    writers[reserve].flush()  # HDF5's caches, fsync, the hold's top-up
                    flushes[reserve].append(time.perf_counter() - started)
        path = writers[RESERVE_BYTES].path
        before = os.stat(path).st_size
        writers[0].close("complete")
        writers[RESERVE_BYTES].close(
            "complete", {f"k{i}": float(i) for i in range(10)},
            {f"m{i}": 1.0 for i in range(40)},
            {"mode": "as-needed", "level": 1.0, "feedforward_N": np.zeros((20, 100))})
        stat = os.stat(path)
    held, bare = (np.asarray(flushes[r]) * 1e3 for r in (RESERVE_BYTES, 0))
    print(f"disk reserve ({stat.st_size / 2**20:.1f} MiB, 50,000 samples, in "
          f"{Path(tempfile.gettempdir())}): a flush takes p50 {np.percentile(held, 50):.2f} ms, "
          f"p99 {np.percentile(held, 99):.2f} ms with the hold's top-up, p50 "
          f"{np.percentile(bare, 50):.2f} ms, p99 {np.percentile(bare, 99):.2f} ms without; "
          f"the close added {(stat.st_size - before) / 2**10:.0f} KiB; left allocated past "
          f"the end after it: {max(0, stat.st_blocks * 512 - stat.st_size) / 2**10:.0f} KiB\n")


def _span(values, fmt: str) -> str:
    values = [v for v in values if np.isfinite(v)]
    if not values:
        return "—"
    low, high = min(values), max(values)
    return fmt.format(low) if low == high else f"{fmt.format(low)}–{fmt.format(high)}"


def _row(fault: str, outcomes) -> str:
    first = outcomes[0]
    seen = _span([o.detected_s for o in outcomes], "{:.3f}")
    if fault == "loop SIGSTOP":
        seen = "lateness " + _span([o.lateness_max_s for o in outcomes], "{:.2f}")
    ticks = _span([float(o.fault_tick - o.injected_tick) for o in outcomes
                   if o.fault_tick >= 0], "{:.0f}")
    lost = [o.lost for o in outcomes]
    lost_text = f"{max(lost)} ({max(lost) * PERIOD_S:.3f} s)" if max(lost) else "0"
    statuses = sorted({o.status if o.readable else "UNREADABLE" for o in outcomes})
    told = "/".join(sorted({o.fate or "—" for o in outcomes}))
    cause = next((c.split(" | ")[0] or c.split(" | ")[1][:40] for c in first.causes), "")
    if fault == "loop SIGSTOP":
        cause = "lateness (the simulator)"
    return (f"{fault:18s} {first.how:9s} {seen:>14s} {ticks:>9s} {lost_text:>11s} "
            f"{'/'.join(statuses):15s} {told:7s} {cause}")


if __name__ == "__main__":
    sys.exit(main())
