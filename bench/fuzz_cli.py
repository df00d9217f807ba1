"""The command line fuzzed at length: ten thousand argument lists or more over every
subcommand and option (tests.app.cli.fuzzing: the same scratch world, drawing and judge as
tests/app/cli/test_fuzz.py, which runs a few hundred), each in a process of its own with a
time limit; prints how many ended in a traceback (or an internal error), a hang, a refusal
on more than one line, or a change to a file they were not given (the goal: 0, 0, 0, 0), and
the first examples of each.

    .venv/bin/python bench/fuzz_cli.py [--cases 10000] [--seed 0] [--timeout 60]
"""

from __future__ import annotations

import argparse
import math
import shutil
import statistics
import sys
import tempfile
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from hypothesis import HealthCheck, Phase, given, seed, settings, strategies as st

from tests.app.cli.fuzzing import (
    TIMEOUT_S,
    Runner,
    Scratch,
    argv,
    changed_files,
    commands,
    judge,
)

KINDS = ("traceback", "hang", "multi-line refusal", "silent refusal", "files changed")
WORLD_RUNS = 1500
"""Runs before the scratch world is made anew (the trials valid runs add fill the disk)."""


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--cases", type=int, default=10_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=TIMEOUT_S,
                        help="seconds after which a run counts as hung")
    args = parser.parse_args()
    table = commands()
    per_command = math.ceil(args.cases / len(table))
    outcomes: Counter = Counter()
    problems: dict[str, list[str]] = {kind: [] for kind in KINDS}
    seconds: list[float] = []
    started = time.monotonic()
    base = Path(tempfile.mkdtemp(prefix="rehab-fuzz-"))
    try:
        world = _World(base, args.timeout)
        for number, (command, sub) in enumerate(sorted(table.items())):
            _fuzz(world, command, sub, per_command, args.seed + number, outcomes, problems,
                  seconds)
            done = sum(outcomes.values())
            print(f"{' '.join(command):<22} {per_command} lists; {done:,} so far, "
                  f"{time.monotonic() - started:.0f} s", file=sys.stderr, flush=True)
        world.close()
    finally:
        shutil.rmtree(base, ignore_errors=True)
    total = sum(outcomes.values())
    print(f"rehab fuzzed with {total:,} argument lists over {len(table)} subcommands in "
          f"{time.monotonic() - started:.0f} s (per run: median "
          f"{1000 * statistics.median(seconds):.0f} ms, slowest {max(seconds):.1f} s)")
    print("exit codes: " + ", ".join(f"{code}: {n:,}" for code, n in sorted(
        outcomes.items(), key=lambda item: str(item[0]))))
    for kind in KINDS:
        print(f"{kind + 's':<22} {len(problems[kind])}")
    for kind in KINDS:
        for example in problems[kind][:10]:
            print(f"  {kind}: {example}")
    return 0 if not any(problems.values()) else 1


class _World:
    """A scratch world and its runner, made anew every WORLD_RUNS runs."""

    def __init__(self, base: Path, timeout_s: float) -> None:
        self.base, self.timeout_s, self.made = base, timeout_s, 0
        self.runs = 0
        self._make()

    def _make(self) -> None:
        self.made += 1
        self.scratch = Scratch.make(self.base / f"world{self.made}")
        self.runner = Runner(self.scratch, self.timeout_s).__enter__()

    def close(self) -> None:
        self.runner.__exit__(None, None, None)
        shutil.rmtree(self.scratch.folder, ignore_errors=True)

    def run(self, args_for) -> tuple:
        if self.runs >= WORLD_RUNS:
            self.close()
            self._make()
            self.runs = 0
        self.runs += 1
        args = args_for(self.scratch)
        before = self.scratch.snapshot()
        run = self.runner.run(args)
        changed = changed_files(before, self.scratch.snapshot(), run.argv, self.scratch)
        return run, judge(run, changed), changed


def _fuzz(world: _World, command, sub, count: int, number: int, outcomes: Counter,
          problems: dict, seconds: list) -> None:
    @seed(number)
    @settings(max_examples=count, deadline=None, database=None, phases=[Phase.generate],
              suppress_health_check=list(HealthCheck))
    @given(st.data())
    def draw(data):
        run, found, changed = world.run(
            lambda scratch: argv(data.draw, command, sub, scratch.paths, scratch.patient))
        seconds.append(run.seconds)
        outcomes["hung" if run.hung else run.code] += 1
        for kind in found:
            detail = "; ".join(changed[:3]) if kind == "files changed" else run.err[-400:]
            problems[kind].append(f"rehab {' '.join(map(repr, run.argv))} -> exit {run.code}: "
                                  f"{' '.join(detail.split())}")

    draw()


if __name__ == "__main__":
    sys.exit(main())
