"""Study-wide analysis on Dask (issue 32, figure for the note): 10,000 simulated trial files
analysed as `rehab study analyse FOLDER` analyses them (app.study), on a local cluster of 1
and of 2 worker processes: the wall time, files per second and the speed-up (goal ≥ 1.7×
with 2 workers on the 2-core machine), and one process reading and measuring files one by
one without Dask, for what Dask costs.

    .venv/bin/python bench/study.py [--files 10000] [--patients 100] [--distinct 4]
                                    [--folder /tmp/rehab-bench-study] [--workers 1 2]

The study is made once and kept in --folder (made again when its size differs):
`--distinct` trials per patient are simulated by the console's headless simulator (a
one-lap D in the thesis mode and a circle in the as-needed mode, 4 s each, the healthy
virtual patient, a new seed each), and the rest of each patient's trials are hard links to
them under the console's file names: every file is read and measured in full, the disk
holds `patients × distinct` files' worth. The files are in the page cache (made just
before, or read by the runs before): the figures are the analysis's, not the disk's. A
cluster's start (its worker processes importing the analysis) is not timed; each run is.
The workers' CPU time says how many cores a run had: on a machine shared with other work,
two workers get less than two cores, and the speed-up says so rather than Dask's overhead.
"""

from __future__ import annotations

import argparse
import datetime
import os
import time
from pathlib import Path

ALPHABET = "0123456789ABCDEFGHJKMNPQRSTVWXYZ"  # app.records.datadir.CODE_PATTERN's
MARKER = "bench-study.txt"


def code_of(index: int) -> str:
    digits = []
    for _ in range(6):
        index, digit = divmod(index, len(ALPHABET))
        digits.append(ALPHABET[digit])
    return "P" + "".join(reversed(digits))


def make_study(folder: Path, files: int, patients: int, distinct: int) -> None:
    from app.records.datadir import trial_stem
    from app.trials.headless import save, simulate
    from core.trial import THESIS_SUBJECT

    shapes = (THESIS_SUBJECT.replace(repetitions=1),
              THESIS_SUBJECT.replace(repetitions=1, shape="circle", radius_m=0.07,
                                     assist="as-needed"))
    marker = folder / MARKER
    wanted = f"{files} {patients} {distinct}\n"
    if marker.is_file() and marker.read_text() == wanted:
        print(f"the study in {folder} is kept ({files} files)")
        return
    if folder.exists():
        raise SystemExit(f"{folder} holds something else: remove it or give another --folder")
    started = time.perf_counter()
    start = datetime.datetime(2026, 1, 5, 9, 0, tzinfo=datetime.UTC)
    per_patient = [files // patients + (1 if i < files % patients else 0)
                   for i in range(patients)]
    seed = 0
    for p, count in enumerate(per_patient):
        code = code_of(1000 + p)
        made: list[Path] = []
        for k in range(count):
            session, number = divmod(k, 10)
            when = start + datetime.timedelta(days=session, minutes=number)
            path = folder / code / f"{trial_stem(code, session + 1, number + 1, when)}.h5"
            path.parent.mkdir(parents=True, exist_ok=True)
            if k < distinct:
                seed += 1
                save(simulate(shapes[k % 2], patient="healthy", seed=seed), path,
                     subject_code=code)
                made.append(path)
            else:
                os.link(made[k % len(made)], path)
        if (p + 1) % 10 == 0:
            print(f"  {p + 1} of {patients} patients made "
                  f"({time.perf_counter() - started:.0f} s)", flush=True)
    marker.write_text(wanted)
    print(f"made {files} files ({patients * distinct} simulated) in {folder} in "
          f"{time.perf_counter() - started:.0f} s")


def one_by_one(selection, count: int) -> float:
    """Files per second of reading and measuring `count` files in this process, no Dask."""
    from app.study.rows import analyse_trials

    trials = selection.trials[:count]
    started = time.perf_counter()
    analyse_trials(trials)
    return len(trials) / (time.perf_counter() - started)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--files", type=int, default=10_000)
    parser.add_argument("--patients", type=int, default=100)
    parser.add_argument("--distinct", type=int, default=4,
                        help="simulated trials per patient; the others are links to them")
    parser.add_argument("--folder", type=Path, default=Path("/tmp/rehab-bench-study"))
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    parser.add_argument("--one-by-one", type=int, default=200,
                        help="files measured in this process without Dask (0: none)")
    args = parser.parse_args()

    from app.study import sources
    from app.study.cluster import study_client
    from app.study.run import analyse_study

    make_study(args.folder, args.files, args.patients, args.distinct)
    selection = sources.from_folder(args.folder)
    print(f"{len(selection)} trial files, {args.patients} patients; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    if args.one_by_one:
        rate = one_by_one(selection, args.one_by_one)
        print(f"one by one in this process, no Dask: {rate:.1f} files/s "
              f"({1000 / rate:.0f} ms a file, {args.one_by_one} files)")
    times = {}
    for workers in args.workers:
        began = time.perf_counter()
        with study_client(workers=workers) as client:
            up = time.perf_counter() - began
            cpu = sum(client.run(time.process_time).values())
            result = analyse_study(selection, client)
            cpu = sum(client.run(time.process_time).values()) - cpu
        times[workers] = result.elapsed_s
        print(f"{workers} worker(s): {len(result.trials)} analysed, {len(result.failures)} "
              f"failed, in {result.elapsed_s:.1f} s: {result.files_per_s:.1f} files/s "
              f"(cluster up in {up:.1f} s, not counted; load average "
              f"{os.getloadavg()[0]:.1f}); the workers' CPU {cpu:.0f} s, "
              f"{1000 * cpu / len(selection):.0f} ms a file, {cpu / result.elapsed_s:.2f} "
              "cores busy on average", flush=True)
    if 1 in times:
        for workers, took in times.items():
            if workers != 1:
                print(f"speed-up with {workers} workers: {times[1] / took:.2f}× "
                      "(goal ≥ 1.7× with 2 on 2 cores)")


if __name__ == "__main__":
    main()
