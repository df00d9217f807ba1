"""Every subcommand of `rehab`, fed arguments made up by hypothesis: each ends with exit code
0 or 2 (argparse's refusals, and the console's one-line errors) and never a traceback.

The arguments are drawn from each subcommand's own options (read off the parser, so a new
option is fuzzed without touching this file), with values that have broken commands
before: empty strings, huge and non-finite numbers, negative ids, text for numbers,
paths to the registry and to folders, invalid UTF-8 made text. The data folder holds one
patient and one trial so that ids reach the code behind them. The example count is
bounded so the suite stays quick; a failure prints the argv that broke.
"""

from __future__ import annotations

import argparse
import contextlib
import io
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from app.cli.main import build_parser, main
from app.trials.headless import simulate_to_file
from core.trial import THESIS_SUBJECT

VALUES = ("", "0", "1", "2", "-1", "3.5", "1e309", "nan", "-inf", "99999999999999999999",
          "abc", "P001", "0x10", " 1", "1,5", "é", "\udcff", "--", "-", "/", ".", "..",
          "registry.sqlite3", "trial.h5", "csv", "mat", "d", "healthy", "right")


def _leaves(parser: argparse.ArgumentParser, path: tuple[str, ...] = ()):
    """(command path, its parser) for every runnable subcommand."""
    subs = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    if not subs and path:
        yield path, parser
    for action in subs:
        for name, sub in action.choices.items():
            yield from _leaves(sub, (*path, name))


def _options(parser: argparse.ArgumentParser):
    """(option string or None for a positional, how many values, its choices)."""
    for action in parser._actions:
        if isinstance(action, argparse._HelpAction) or "--data-dir" in action.option_strings:
            continue
        nargs = action.nargs
        count = 0 if nargs == 0 else (nargs if isinstance(nargs, int) else 1)
        yield (action.option_strings[-1] if action.option_strings else None, count,
               tuple(action.choices) if action.choices else ())


ROOT = Path(__file__).resolve().parents[3]
PARSER, _ = build_parser()
COMMANDS = sorted(path for path, _ in _leaves(PARSER))


@pytest.fixture(scope="module")
def data_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("fuzz")
    assert main(["--data-dir", str(folder / "data"), "patients", "add", "--first-name", "Ada",
                 "--last-name", "Test", "--birth-year", "1950"]) == 0
    simulate_to_file(THESIS_SUBJECT.replace(repetitions=1, duration_s=3.0),
                     folder / "trial.h5")
    return folder


def _visible(folder: Path) -> list[str]:
    """The folder's entries, without the tools' hidden caches (.hypothesis, .pytest_cache)."""
    return sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))


def _argv(draw, path: tuple[str, ...], folder: Path) -> list[str]:
    parser = dict(_leaves(PARSER))[path]
    value = st.one_of(st.sampled_from(VALUES), st.text(max_size=6),
                      st.sampled_from((str(folder / "trial.h5"), str(folder),
                                       str(folder / "data" / "registry.sqlite3"))))
    argv = list(path)
    for option, count, choices in _options(parser):
        if option is not None and not draw(st.booleans()):
            continue
        if option is None and draw(st.integers(0, 4)) == 0:
            continue  # a positional left out
        pick = st.sampled_from(choices) if choices and draw(st.booleans()) else value
        if option is not None:
            argv.append(option)
        argv.extend(str(draw(pick)) for _ in range(count))
    if draw(st.integers(0, 5)) == 0:
        argv.append(draw(value))  # one argument too many
    return [*argv, "--data-dir", str(folder / "data")]


@pytest.mark.slow
@pytest.mark.parametrize("path", COMMANDS, ids=" ".join)
def test_every_command_ends_in_one_line_or_success(path, data_dir, monkeypatch):
    monkeypatch.setenv("REHAB_DATA_DIR", str(data_dir / "data"))
    # fuzzed relative paths ("0", ".") are written where the command runs: in a scratch
    # folder, not in the checkout (a run from the repository's root once left a trial
    # file named "0" and a synthetic EMG subject there)
    checkout = _visible(ROOT)
    scratch = data_dir / "cwd"
    scratch.mkdir(exist_ok=True)
    monkeypatch.chdir(scratch)

    @settings(max_examples=12, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
    @given(st.data())
    def check(data):
        argv = _argv(data.draw, path, data_dir)
        # a command that simulates must stay short: the fuzz is about its input handling
        if path == ("run",):
            argv += ["--duration", "3", "--repetitions", "1"]
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
            try:
                code = main(argv)
            except SystemExit as exc:  # argparse: 0 for --help, 2 for a refusal
                code = exc.code
        assert code in (0, 2), f"rehab {' '.join(argv)} exited {code}: {err.getvalue()}"
        assert "Traceback" not in err.getvalue(), f"rehab {' '.join(argv)}"
        if code == 2:
            lines = [line for line in err.getvalue().splitlines() if line.strip()]
            assert lines, f"rehab {' '.join(argv)}: exit 2 with nothing said"

    check()
    assert _visible(ROOT) == checkout, "the fuzz wrote into the checkout"


def test_the_fuzz_reaches_every_command():
    """Every command group is fuzzed: the list is read off the parser."""
    assert {p[0] for p in COMMANDS} >= {"check", "run", "patients", "trials", "progress",
                                         "report", "export", "gains"}
