"""`rehab emg model`: an EMG-to-torque model validated held out on the researcher's trials,
and refused as the patient's force estimate, in one line saying why, unless it passes
(core.emg.models.USABLE_R2). On two synthetic subjects, the second with a bad deltoid MVC."""

import shutil

import h5py
import pytest

from app.emg.session import Contraction, session_mvc
from app.emg.subjects import Subject, record_trial, write_contractions
from tests.app.cli.running import run

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


def test_a_model_that_passes_held_out_may_feed_the_assistance(trials, capsys):
    held = str(trials[1])  # subject 1's second trial
    code, out, err = run(["emg", "model", *map(str, trials), "--model", "network",
                          "--test", held, "--for-assistance"], capsys)
    assert code == 0, err
    assert "held-out trials" in out
    assert "passes" in out
    assert "network passed every held-out validation" in out
    # the same split does not pass the muscle model, which does not reach 0.60 at the
    # shoulder
    code, _, err = run(["emg", "model", *map(str, trials), "--model", "muscle", "--test",
                        held, "--for-assistance"], capsys)
    assert code == 2
    assert "muscle model, held out (held-out trials): shoulder R²" in err


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
    with h5py.File(other, "r+") as f:
        del f["emg"]
    moved = shutil.copy(trials[0], tmp_path / "moved.h5")  # an electrode on another muscle
    with h5py.File(moved, "r+") as f:
        table = f["emg/channels"][()]
        table[0]["muscle"] = "posterior_deltoid"
        f["emg/channels"][...] = table
    code, _, err = run(["emg", "model", *make_args(trials, other)], capsys)
    assert code == 2
    assert expected in err
    assert err.count("\n") == 1
