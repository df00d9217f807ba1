"""`rehab emg model`: an EMG-to-torque model validated held out on the researcher's trials,
and refused as the patient's force estimate, in one line saying why, unless it passes
(core.emg.models.USABLE_R2). On two synthetic subjects, the second with a bad deltoid MVC."""

import shutil

import h5py
import pytest

from app.emg.session import Contraction, session_mvc
from app.emg.subjects import Subject, record_trial, write_contractions
from tests.app.cli.running import run
from tests.trialfiles import edited

pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


@pytest.fixture(scope="module")
def trials(tmp_path_factory):
    folder = tmp_path_factory.mktemp("models")
    out = []
    for number, bad in ((1, None), (2, {"anterior_deltoid": 0.15})):
        subject = Subject.drawn(number, bad_mvc=bad)
        paths = [record_trial(folder / f"S{number}_t{k}.h5", subject, seed=k,
                              engine="python").path for k in (1, 2)]
        contractions = write_contractions(folder, subject, session=1)
        session_mvc(paths, [Contraction(m, p, ch) for m, (p, ch) in contractions.items()],
                    full_scale_V=subject.electrodes.full_scale_V)
        out += paths
    return out


def test_a_model_that_does_not_generalise_is_refused_saying_why(trials, capsys):
    code, out, err = run(["emg", "model", *map(str, trials), "--model", "linear",
                          "--for-assistance"], capsys)
    assert code == 2
    assert "leave subject SYN1 out" in out
    assert "leave subject SYN2 out" in out
    assert out.count("fails") == 2
    assert err.count("\n") == 1
    assert "refused as the patient's force estimate: linear, held out (leave subject SYN1 " \
           "out): shoulder R² " in err
    assert "below 0.60" in err
    assert "(2 of 2 validations fail)" in err
    # without --for-assistance it is a report, not a refusal
    code, out, _ = run(["emg", "model", *map(str, trials), "--model", "linear"], capsys)
    assert code == 0
    assert out.count("fails") == 2


def test_a_model_whose_torques_pass_is_still_refused_when_its_force_misjudges_the_cone(
        trials, data, capsys):
    """Held-out torque R² above 0.9, but the force those torques imply, replayed as the
    live console would get it, judges the 20° cone as the sensor does on too few samples:
    refused, and nothing saved."""
    held = str(trials[1])  # subject 1's second trial
    code, out, err = run(["emg", "model", *map(str, trials), "--model", "network",
                          "--test", held, "--for-assistance", "--save", "net"], capsys)
    assert code == 2
    assert "held-out trials" in out
    assert "cone judged alike" in out
    assert "about the 20° tolerance cone, below 80%" in err
    assert err.count("\n") == 1
    assert not (data / "models" / "emg" / "net.json").exists()
    # the muscle model does not even reach 0.60 at the shoulder on this split
    code, _, err = run(["emg", "model", *map(str, trials), "--model", "muscle", "--test",
                        held, "--for-assistance"], capsys)
    assert code == 2
    assert "muscle model, held out (held-out trials): shoulder R²" in err


def test_latency_replays_every_run_s_force_as_its_help_says(trials, capsys, monkeypatch):
    """`--latency`'s help said "with --for-assistance:" while every run's force (its cone
    judged alike) is replayed with it, and its description left out the cone's 80 %."""
    held = str(trials[1])
    forces = []
    for latency in ("0", "0.5"):
        code, out, err = run(["emg", "model", *map(str, trials), "--model", "linear",
                              "--test", held, "--latency", latency], capsys)
        assert code == 0, err
        forces.append(out[out.index("force RMSE"):].split("passes")[0].split("fails")[0])
    assert forces[0] != forces[1]  # half a second later, the force it implies differs
    monkeypatch.setenv("COLUMNS", "1000")  # argparse wraps no line (nor a --for-assistance)
    code, out, _ = run(["emg", "model", "--help"], capsys)
    assert code == 0
    text = " ".join(out.split())
    assert "with or without --for-assistance" in text
    assert "with --for-assistance: how late" not in text
    assert "on 80% of the samples" in text
    assert "`rehab run --force-estimate` refuses a later source" in text


@pytest.fixture(scope="module")
def wide(emg_subject_1):
    """Subject 1's session with a 30° cone: the cone its EMG estimate is shown to judge
    (recorded once for the run: tests/conftest.py)."""
    return list(emg_subject_1)


def test_a_passing_model_is_saved_and_feeds_a_trial_s_assistance(wide, data, capsys):
    """`rehab emg model --for-assistance --save NAME`, then `rehab run --force-estimate
    NAME`: the trial's assistance judges the force estimated from the subject's EMG."""
    code, out, err = run(["emg", "model", *map(str, wide), "--test", str(wide[-1]),
                          "--for-assistance", "--latency", "0.04", "--save", "s1"], capsys)
    assert code == 0, err
    assert "network passed every held-out validation" in out
    saved = data / "models" / "emg" / "s1.json"
    assert f"saved as s1 ({saved})" in out
    assert saved.stat().st_mode & 0o777 == 0o600
    assert (data / "models" / "emg").stat().st_mode & 0o777 == 0o700
    before = saved.read_bytes()
    # a second save under the name is refused; the first file is kept as it was
    code, _, err = run(["emg", "model", *map(str, wide), "--test", str(wide[-1]),
                        "--for-assistance", "--latency", "0.04", "--save", "s1"], capsys)
    assert code == 2
    assert "already exists" in err
    assert saved.read_bytes() == before

    out_file = data.parent / "emg-fed.h5"
    code, out, err = run(["run", "--force-estimate", "s1", "--tolerance", "30",
                          "--repetitions", "1", "--output", str(out_file)], capsys)
    assert code == 0, err
    assert "Trial complete" in out
    with h5py.File(out_file, "r") as f:
        assert f["parameters"].attrs["force_estimate"] == "s1"
        assert len(f["assistance/estimate_force"]) > 40  # one every 0.0625 s
        assert "emg" in f
        assert "mvc" in f["emg"]

    # refusals, one line each: a cone narrower than validated, a missing model, a
    # subject with another electromechanical delay than the model was validated for
    for argv, expected in (
            (["--tolerance", "20"], "validated with a 30° tolerance cone"),
            (["--force-estimate", "nope"], "missing"),
            (["--force-estimate", "../s1"], "is not a model name"),
            (["--emg-subject", "3"], "needs --force-estimate"),
            (["--repetitions", "100", "--duration", "20"], "give at most 1800 s of exercise")):
        args = ["run", "--repetitions", "1", "--output", str(data.parent / "x.h5")]
        if "--force-estimate" not in argv and "--emg-subject" not in argv:
            args += ["--force-estimate", "s1"]
        code, _, err = run([*args, *argv], capsys)
        assert code == 2, argv
        assert expected in err, err
        assert err.count("\n") == 1
    assert not (data.parent / "x.h5").exists()


def test_save_needs_for_assistance_and_a_name(wide, capsys):
    code, _, err = run(["emg", "model", *map(str, wide), "--save", "x"], capsys)
    assert code == 2
    assert "--save needs --for-assistance" in err
    code, _, err = run(["emg", "model", *map(str, wide), "--for-assistance", "--save",
                        "a/b"], capsys)
    assert code == 2
    assert "is not a model name" in err
    code, _, err = run(["emg", "model", *map(str, wide), "--for-assistance", "--latency",
                        "nan"], capsys)
    assert code == 2
    assert "--latency nan" in err


@pytest.mark.parametrize(("make_args", "expected"), [
    (lambda t, o: [str(t[0]), str(t[1])], "all the trials are of one subject"),
    (lambda t, o: [*map(str, t), "--test", str(o)], "not among the trials given"),
    (lambda t, o: [str(t[0]), str(t[1]), "--test", str(t[0]), "--test", str(t[1])],
     "every trial is held out"),
    (lambda t, o: [*map(str, t), str(o)], "has no EMG"),
    (lambda t, o: [*map(str, t), str(o.with_name("moved.h5"))],
     "a model takes the same muscles from every trial"),
])
def test_bad_input_is_one_line(trials, tmp_path, capsys, make_args, expected):
    other = tmp_path / "other.h5"
    shutil.copy(trials[0], other)
    with edited(other) as f:
        del f["emg"]
    moved = shutil.copy(trials[0], tmp_path / "moved.h5")  # an electrode on another muscle
    with edited(moved) as f:
        table = f["emg/channels"][()]
        table[0]["muscle"] = "posterior_deltoid"
        f["emg/channels"][...] = table
    code, _, err = run(["emg", "model", *make_args(trials, other)], capsys)
    assert code == 2
    assert expected in err
    assert err.count("\n") == 1
