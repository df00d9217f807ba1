"""`rehab emg …` as a researcher types it: import, MVC, show; bad input as one line and exit 2
(the demo, record and streams: test_cli_emg_demo.py, _record.py, _record_lsl.py,
_streams.py)."""

import shutil
from pathlib import Path

import pytest

from app.emg.subjects import Subject, record_trial, write_contractions
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from device.recording.emgfile import read_emg
from tests.app.cli.running import run

DATA = Path(__file__).parents[2] / "data" / "emg"


pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


@pytest.fixture(scope="module")
def made(tmp_path_factory):
    folder = tmp_path_factory.mktemp("emg")
    plain = folder / "plain.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python"), plain)
    subject = Subject.drawn(1)
    synthetic = record_trial(folder / "synthetic.h5", subject, seed=0, engine="python")
    return plain, synthetic.path, write_contractions(folder, subject, session=1)


def test_import_the_trigno_sample_then_show(made, tmp_path, capsys):
    trial = shutil.copy(made[0], tmp_path / "t.h5")
    code, out, err = run(["emg", "import", str(trial), str(DATA / "trigno_export.csv"),
                          "--muscles", "biceps,triceps,anterior_deltoid"], capsys)
    assert code == 0, err
    assert "stored 3 EMG channels (biceps, triceps, anterior_deltoid) at 1925.93 Hz" in out
    assert "ACC1.X" in out  # the skipped accelerometer is said
    assert read_emg(trial).muscles == ("biceps", "triceps", "anterior_deltoid")
    said = [line.strip() for line in out.splitlines() if line.strip().startswith("note:")]
    assert said  # the sample file is shorter than the trial: how much it covers
    code, out, _ = run(["emg", "show", str(trial)], capsys)
    assert code == 0
    assert "no MVC yet" in out
    # what the import said is kept with the EMG, and shown again
    assert all(note in out for note in said), (said, out)


def test_mvc_then_show_in_percent_of_mvc(made, tmp_path, capsys):
    trial = shutil.copy(made[1], tmp_path / "s.h5")
    args = ["emg", "mvc", str(trial), "--full-scale", "0.011"]
    for muscle, (path, channel) in made[2].items():
        args += ["--contraction", f"{muscle}={path}:{channel}"]
    code, out, err = run(args, capsys)
    assert code == 0, err
    assert out.count(" ok") == 3
    assert "stored in 1 trial file(s)" in out
    code, out, _ = run(["emg", "show", str(trial)], capsys)
    assert code == 0
    lines = [line for line in out.splitlines() if line.startswith(("biceps", "triceps",
                                                                   "anterior_deltoid"))]
    assert len(lines) == 3
    assert all(line.rstrip().endswith("ok") for line in lines)
    assert all("%" in line for line in lines)


def test_show_after_one_muscle_s_mvc_shows_it_and_names_the_others(made, tmp_path, capsys):
    """MVCs recorded one muscle at a time are kept side by side; `emg show` refused the
    whole trial ('no MVC for triceps, anterior_deltoid') until all were there."""
    trial = shutil.copy(made[1], tmp_path / "s.h5")
    path, channel = made[2]["biceps"]
    code, _, err = run(["emg", "mvc", str(trial), "--contraction",
                        f"biceps={path}:{channel}"], capsys)
    assert code == 0, err
    code, out, err = run(["emg", "show", str(trial)], capsys)
    assert code == 0, err
    rows = {line.split()[0]: line for line in out.splitlines()[2:]}
    assert "%" in rows["biceps"]
    assert "no MVC yet" in rows["triceps"]
    assert "no MVC yet" in rows["anterior_deltoid"]


@pytest.mark.parametrize(("args", "expected"), [
    (["emg", "import", "missing.h5", "x.csv"], "no such trial file"),
    (["emg", "show", "99"], "no registry"),
    (["emg", "import", "{plain}", "missing.csv"], "does not exist"),
    (["emg", "import", "{plain}", str(DATA / "plain.csv"), "--offset", "nan"], "--offset"),
    # EMG wholly beside the trial was stored ("covers 0 %"), and at 1e300 s stored times
    # that no longer increased, so the trial's EMG then read as damaged
    (["emg", "import", "{plain}", str(DATA / "plain.csv"), "--offset", "1e9"],
     "an offset of 1e+09 s puts the EMG at trial time 1e+09–1e+09 s, none of it within "
     "the trial (0–"),
    (["emg", "import", "{plain}", str(DATA / "plain.csv"), "--offset=-1e9"],
     "none of it within the trial"),
    (["emg", "import", "{plain}", str(DATA / "plain.csv"), "--offset", "1e300"],
     "none of it within the trial"),
    (["emg", "import", "{plain}", str(DATA / "plain.csv"), "--muscles", "a,b"],
     "2 muscles given for 3"),
    (["emg", "mvc", "{plain}", "--contraction", "biceps"], "MUSCLE=FILE"),
    (["emg", "mvc", "{plain}", "--contraction", f"biceps={DATA / 'plain.csv'}"], "has no EMG"),
    (["emg", "show", "{plain}"], "has no EMG"),
    # a file that is not HDF5 (a report given by mistake): the console's words, not h5py's
    (["emg", "show", str(DATA / "plain.csv")], "is not an HDF5 file"),
    (["emg", "mvc", str(DATA / "plain.csv"), "--contraction", f"b={DATA / 'plain.csv'}"],
     "is not an HDF5 file"),
    (["emg", "streams", "--wait", "0"], "--wait"),
    (["emg", "record", "usb:x", "--output", "{plain}.csv"], "give trigno:HOST, avanti:HOST or lsl"),
    (["emg", "record", "lsl:x", "--output", "{plain}.csv", "--seconds", "0"], "--seconds 0"),
    (["emg", "record", "trigno:127.0.0.1", "--output", "{plain}.csv", "--command-port", "1"],
     "connection refused"),
    (["emg", "frobnicate"], "invalid choice"),
    (["emg", "demo", "{plain}.d", "--subject", "0"], "--subject 0"),
    (["emg", "demo", "{plain}.d", "--bad-mvc", "2"], "--bad-mvc 2"),
    (["emg", "mvc", "{plain}", "--contraction", "b=f", "--mains", "55"], "invalid choice"),
])
def test_bad_input_is_one_line_and_exit_2(made, tmp_path, capsys, args, expected):
    trial = shutil.copy(made[0], tmp_path / "p.h5")
    args = [a.replace("{plain}", str(trial)) for a in args]
    code, _, err = run(args, capsys)
    assert code == 2
    assert expected in err
    assert len(err.strip().splitlines()) == 1
    assert "Traceback" not in err
