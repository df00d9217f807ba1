"""`rehab emg demo`: a synthetic subject's trials and MVC files to try the commands on."""

from pathlib import Path

import pytest

from tests.app.cli.running import run

DATA = Path(__file__).parents[2] / "data" / "emg"


pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


def test_demo_writes_a_trial_to_try_the_commands_on(tmp_path, capsys):
    code, out, err = run(["emg", "demo", str(tmp_path / "demo"), "--bad-mvc", "0.08",
                          "--engine", "python"], capsys)
    assert code == 0, err
    mvc_command = next(line for line in out.splitlines() if line.startswith("next: "))
    code, out, err = run(mvc_command.removeprefix("next: rehab ").split(), capsys)
    assert code == 0, err
    assert "anterior_deltoid" in out
    assert "FLAGGED: below_trial_activity" in out
    assert "warning: anterior_deltoid: the trial reaches" in out
    code, out, _ = run(["emg", "show", str(tmp_path / "demo" / "synthetic_S2.h5")], capsys)
    assert code == 0
    assert out.splitlines()[0].endswith(" s (synthetic)"), out  # was "(synthetic, )"
    code, _, err = run(["emg", "demo", str(tmp_path / "demo"), "--engine", "python"], capsys)
    assert code == 2
    assert "already exists" in err


def test_demo_makes_the_trials_an_emg_model_for_the_assistance_needs(tmp_path, capsys):
    """The README's chain `emg model --for-assistance --save`, then `run --force-estimate
    --tolerance 30`, needs several trials of one subject at a wide cone; `emg demo` made one
    trial at the thesis's 20°, so a researcher without recorded EMG could not start it."""
    import math

    from app.trials.reader import read_trial

    code, out, err = run(["emg", "demo", str(tmp_path / "d"), "--subject", "1",
                          "--trials", "2", "--tolerance", "30", "--engine", "python"], capsys)
    assert code == 0, err
    trials = [tmp_path / "d" / f"synthetic_S1_{k}.h5" for k in (1, 2)]
    for path in trials:
        assert math.degrees(read_trial(path).parameters.tolerance_rad) == pytest.approx(30.0)
    lines = {line.split(": ", 1)[0]: line.split(": ", 1)[1] for line in out.splitlines()
             if line.startswith(("next: ", "and: "))}
    code, _, err = run(lines["next"].removeprefix("rehab ").split(), capsys)
    assert code == 0, err
    model = lines["and"].removeprefix("rehab ").split()
    assert model[:2] == ["emg", "model"]
    assert model[model.index("--test") + 1] == str(trials[1])
    # the linear baseline, to be quick: the trials are taken, held out at their own cone
    code, out, err = run([*model[:model.index("--for-assistance")], "--model", "linear"],
                         capsys)
    assert code == 0, err
    assert "held-out trials" in out
    assert "(30°)" in out


@pytest.mark.parametrize(("option", "said"), [
    (["--trials", "0"], "--trials 0: give a number from 1 to 10"),
    (["--trials", "11"], "--trials 11: give a number from 1 to 10"),
    (["--tolerance", "nan"], "--tolerance = NaN is not allowed; allowed: a cone from 1 to "
                             "90 degrees"),
    (["--tolerance", "95"], "--tolerance = 95 is not allowed; allowed: a cone from 1 to 90 "
                            "degrees"),
])
def test_demo_refuses_a_bad_count_or_cone_in_one_line(tmp_path, capsys, option, said):
    code, _, err = run(["emg", "demo", str(tmp_path / "d"), *option], capsys)
    assert code == 2
    assert said in err
    assert err.count("\n") == 1
    assert not (tmp_path / "d").exists()
