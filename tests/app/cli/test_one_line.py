"""The reproducers of issue 28 #15, each once a traceback, a hang or a refusal of several
lines: now one line and exit 2 (or the help, exit 0). The fuzz test
(tests/app/cli/test_fuzz.py) draws such inputs for every option; these are the ones the
issue names, run as a user types them."""

from __future__ import annotations

import os

import pytest

from app.trials.headless import simulate_to_file
from core.trial import THESIS_SUBJECT
from tests.app.cli.running import run

pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


@pytest.fixture(scope="module")
def trial(tmp_path_factory):
    path = tmp_path_factory.mktemp("one-line") / "trial.h5"
    simulate_to_file(THESIS_SUBJECT.replace(repetitions=1, duration_s=3.0), path)
    return path


@pytest.fixture
def files(tmp_path, trial, capsys):
    assert run(["patients", "add", "--first-name", "A"], capsys)[0] == 0
    loop = tmp_path / "loop"
    os.symlink(loop, loop)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    long_line = tmp_path / "long.csv"
    long_line.write_text("time,EMG1\n0," + "1" * 140_000 + "\n")
    header_only = tmp_path / "header.csv"
    header_only.write_text("Label: EMG1 Sampling frequency: 1925.926 Unit: V Domain: Time\n\n"
                           "X[s],EMG1\n")
    pendulum = tmp_path / "p.h5"
    assert run(["learn", "pendulum", "--speeds", "1", "2", "--output", str(pendulum)],
               capsys)[0] == 0
    return {"trial": str(trial), "loop": str(loop), "fifo": str(fifo),
            "long": str(long_line), "header": str(header_only), "pendulum": str(pendulum),
            "deep": str(tmp_path / "/".join(["a"] * 1500) / "x.h5"),
            "long name": str(tmp_path / ("x" * 300)), "out": str(tmp_path / "out")}


CASES = [
    ["pose", "²"],
    ["pose", "99999999999999999999"],
    ["report", "9" * 4400],
    ["emg", "show", "9" * 4400],
    ["export", "--trial", "9" * 4400],
    ["emg", "import", "{loop}", "{loop}"],
    ["pose", "{loop}"],
    ["learn", "evaluate", "--model", "{loop}", "--data", "{loop}"],
    ["learn", "pendulum", "--speeds", "1", "--output", "{loop}/x.h5"],
    ["export", "--folder", "{loop}"],
    ["--data-dir", "{loop}", "patients"],
    ["learn", "pendulum", "--speeds", "1", "--output", "{long name}"],
    ["emg", "import", "{trial}", "{long name}"],
    ["pose", "{long name}"],
    ["emg", "demo", "/dev/null"],
    ["pose", "{trial}", "--marks", "/dev/zero"],
    ["pose", "{trial}", "--marks", "{fifo}"],
    ["emg", "import", "{trial}", "{fifo}"],
    ["learn", "pendulum", "--speeds", "1", "--output", "{deep}"],
    ["learn", "components", "--model", "{pendulum}", "--data", "{pendulum}", "--output",
     "x.h5"],
    ["emg", "import", "{trial}", "{long}"],
    ["emg", "import", "{trial}", "{header}"],
]


@pytest.mark.parametrize("argv", CASES, ids=lambda a: " ".join(a)[:60])
def test_each_reproducer_is_one_line_and_exit_2(files, argv, capsys):
    argv = [a.format(**files) if "{" in a else a for a in argv]
    code, _, err = run(argv, capsys)
    assert code == 2, err
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1, err


def test_a_system_folder_as_a_study_is_one_line_or_an_empty_export(files, capsys):
    code, _, err = run(["export", "--folder", "/proc", "--output", files["out"]], capsys)
    assert code in (0, 2), err
    assert "Traceback" not in err
    assert code == 0 or len(err.strip().splitlines()) == 1


def test_every_help_is_printed(capsys):
    """`rehab emg --help` raised a ValueError on the '%' of '% MVC': every parser's help,
    the groups' too, prints."""
    import argparse

    from app.cli.main import build_parser

    parser, _ = build_parser()
    paths = [()]
    pending = [((), parser)]
    while pending:
        path, here = pending.pop()
        for action in here._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, sub in action.choices.items():
                    paths.append((*path, name))
                    pending.append(((*path, name), sub))
    for path in paths:
        code, out, err = run([*path, "--help"], capsys)
        assert code == 0, (path, err)
        assert out.startswith("usage: rehab")


@pytest.mark.parametrize(("argv", "said"), [
    (["check", "--radius", "nan", "--shoulder", "-0.10", "0.72"],
     "--radius (radius_m) = NaN is not allowed; allowed: a finite number in [0.02, 0.25] m"),
    (["check", "--radius", "0.08", "--shoulder", "inf", "0.72"],
     "allowed: a finite number in [-1.5, 1.5] m"),
    (["patients", "add", "--first-name", "B", "--body-mass", "nan"],
     "--body-mass (body_mass_kg) = NaN is not allowed; allowed: a finite number in [20, "
     "250] kg"),
    (["run", "--duration", "nan"], "allowed: a finite number in [1, 120] s"),
], ids=lambda a: " ".join(a)[:50] if isinstance(a, list) else "")
def test_nan_or_inf_is_told_the_range_to_give(argv, said, capsys):
    """nan passes float(), and a range check refused it as 'allowed: a finite number m':
    what was wrong, not what to give. The one line names the range too."""
    code, _, err = run(argv, capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert said in err


@pytest.mark.parametrize(("argv", "said"), [
    (["patients", "add", "--first-name", "B", "--body-mass", "70kg"],
     "rehab patients add: error: --body-mass '70kg' is not a number (kg) (see rehab patients "
     "add --help)"),
    (["patients", "add", "--upper-arm", "30cm"],
     "--upper-arm '30cm' is not a number (shoulder to elbow, m)"),
    (["run", "--seed", "1.5"], "rehab run: error: --seed '1.5' is not a whole number (see"),
])
def test_a_value_that_is_no_number_is_said_so_with_its_unit(argv, said, capsys):
    """argparse said "argument --body-mass: invalid float value: '70kg'": a newcomer who
    typed the unit learnt neither that a bare number was wanted nor in which unit."""
    code, _, err = run(argv, capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert said in err
