"""Every subcommand of `rehab`, fed argument lists made up by hypothesis (issue 28: 83 of
3,000 fuzzed lists ended in a traceback, 9 in refusals of several lines, 5 hung): each run
ends at once (a child killed after tests.app.cli.fuzzing.TIMEOUT_S is a hang), exits 0, 1
(a batch export that skipped trials) or 2 with one line saying why, never a traceback or an
internal error, changes no file it was not given, and writes nothing outside its scratch
folder (HOME, TMPDIR, the config and the data folder are all in it).

The options of each subcommand are read off the parser, so a new option is fuzzed without
touching this file; the values are the kinds that broke commands before (tests.app.cli
.fuzzing: a link loop, a 300-character name, a path 1,500 folders deep, a named pipe,
/dev/zero, /proc, a CSV line over 131 KB, a Trigno export with a header only, model JSON
with NaN or 200,000 levels of nesting, a 4,400-digit number, '²'…). The examples are
derandomised and bounded so the suite stays within a few minutes: EXAMPLES argument lists a
command (each a forked run of the whole command, a trial or a PDF for some);
REHAB_FUZZ_EXAMPLES=100 runs more in the test, and `bench/fuzz_cli.py` runs ten thousand and
more and prints what it found.
"""

from __future__ import annotations

import os

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from tests.app.cli.fuzzing import ROOT, Runner, Scratch, changed_files, commands, judge

COMMANDS = commands()
EXAMPLES = int(os.environ.get("REHAB_FUZZ_EXAMPLES", "10"))
"""Argument lists a command (16 until 2026-12; the first ten of a derandomised run are the
same lists)."""


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    scratch = Scratch.make(tmp_path_factory.mktemp("fuzz"))
    with Runner(scratch) as runner:
        yield scratch, runner


def _visible(folder) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))


@pytest.mark.slow
@pytest.mark.parametrize("command", sorted(COMMANDS), ids=" ".join)
def test_every_command_ends_in_one_line_or_success(command, world):
    scratch, runner = world
    checkout = _visible(ROOT)
    found = []

    @settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
              suppress_health_check=list(HealthCheck))
    @given(st.data())
    def check(data):
        from tests.app.cli.fuzzing import argv

        args = argv(data.draw, command, COMMANDS[command], scratch.paths, scratch.patient)
        before = scratch.snapshot()
        run = runner.run(args)
        problems = judge(run, changed_files(before, scratch.snapshot(), run.argv, scratch))
        if problems:
            found.append(f"{', '.join(problems)}: rehab {' '.join(map(repr, args))} -> exit "
                         f"{run.code}: {run.err[-600:]}")

    check()
    assert found == []
    assert _visible(ROOT) == checkout, "the fuzz wrote into the checkout"


def test_the_fuzz_reaches_every_command():
    """Every command group is fuzzed: the list is read off the parser."""
    assert {c[0] for c in COMMANDS} >= {"check", "run", "patients", "trials", "progress",
                                        "report", "export", "pose", "gains", "learn", "emg"}


def test_a_report_written_again_counts_as_named_only_when_asked_to(tmp_path):
    """`rehab report ID --force` (or --overwrite, or a prefix argparse takes) writes the data
    folder's report of that trial again, as asked; without it the change is the fuzzer's
    finding (bench/fuzz_cli.py counted 21 such runs as files changed they were not given)."""
    import stat
    from types import SimpleNamespace

    scratch = SimpleNamespace(folder=tmp_path, data=tmp_path / "data")
    report = str(scratch.data / "reports" / "P1" / "P1_S001_T001.pdf")
    trial = str(scratch.data / "trials" / "P1" / "P1_S001_T001.h5")
    before = {report: (stat.S_IFREG | 0o600, 10, "old"), trial: (stat.S_IFREG | 0o600, 9, "t")}
    after = {report: (stat.S_IFREG | 0o600, 11, "new"), trial: (stat.S_IFREG | 0o600, 9, "t")}
    for asked in (("report", "1", "--force"), ("report", "1", "--overwrite"),
                  ("report", "1", "--forc", "--first-name")):
        assert changed_files(before, after, asked, scratch) == [], asked
    for unasked in (("report", "1"), ("report", "1", "--first-name"),
                    ("trials", "--force"), ("report", "x", "--force")):
        assert changed_files(before, after, unasked, scratch) == [f"{report}: changed"], \
            unasked
