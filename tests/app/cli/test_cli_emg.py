"""`rehab emg …` as a researcher types it: import, MVC, show; bad input as one line and exit 2."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from app.emg.subjects import Subject, record_trial, write_contractions
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from device.emg.files import read_emg_file
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


def _fake_trigno():
    """The fake Trigno Control Utility of the device tests (tests/device/fakes)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "trigno_server", Path(__file__).parents[2] / "device" / "fakes" / "trigno_server.py")
    fake = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(fake)
    return fake


def test_record_a_guided_mvc_from_the_fake_trigno(tmp_path, capsys):
    fake = _fake_trigno()
    out_file = tmp_path / "mvc.csv"
    with fake.FakeTrignoServer() as server:
        code, out, err = run(["emg", "record", "trigno:127.0.0.1", "--seconds", "0.6",
                              "--output", str(out_file), "--muscle", "biceps", "--channel", "3",
                              "--rest", "0",
                              "--command-port", str(server.command_port),
                              "--data-port", str(server.data_port)], capsys)
    assert code == 0, err
    assert "Contract the biceps as hard as you can" in out
    assert "channels at 1925.93 Hz from trigno:127.0.0.1" in out
    # 0.6 s cannot hold a maximal effort for a second: flagged at once
    assert "FLAGGED: too_short" in out
    data = read_emg_file(out_file)
    assert data.samples.shape[1] == 16
    np.testing.assert_allclose(data.samples[:, 2],
                               fake.default_signal(np.arange(data.t_s.size))[:, 2], rtol=1e-6)
    code, _, err = run(["emg", "record", "trigno:127.0.0.1", "--output", str(out_file)], capsys)
    assert code == 2
    assert "already exists" in err


def test_a_channel_the_source_lacks_is_refused_before_the_patient_is_told_to_contract(
        tmp_path, capsys):
    """`--channel 17` on a 16-slot base station was refused only after 'Contract the biceps
    as hard as you can … now' and the whole recording: the patient pushed for nothing."""
    fake = _fake_trigno()
    out_file = tmp_path / "mvc.csv"
    with fake.FakeTrignoServer() as server:
        code, out, err = run(["emg", "record", "trigno:127.0.0.1", "--seconds", "0.6",
                              "--output", str(out_file), "--muscle", "biceps", "--channel",
                              "17", "--command-port", str(server.command_port),
                              "--data-port", str(server.data_port)], capsys)
    assert code == 2
    assert "Contract" not in out
    assert err.count("\n") == 1
    assert "--channel 17: the source has channels 1 to 16" in err
    assert not out_file.exists()


def test_record_refuses_a_muscle_it_does_not_know_saying_the_ones_it_does(tmp_path, capsys):
    """`--muscle bicep` was taken as it was typed: the patient was asked to contract 'the
    bicep' and the CSV's MVC was of a muscle no trial names. Refused in one line that lists
    the muscles accepted (app.emg.muscle_words), before any source is opened."""
    from app.emg.muscle_words import MUSCLE_WORDS

    out_file = tmp_path / "mvc.csv"
    code, out, err = run(["emg", "record", "lsl:nothing-here", "--output", str(out_file),
                          "--muscle", "bicep"], capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1
    assert "argument --muscle: invalid choice: 'bicep'" in err
    assert all(muscle in err for muscle in MUSCLE_WORDS)
    assert not out
    assert not out_file.exists()


class _EndingSource:
    """A source that streams 0.3 s at 1 kHz, then fails as an unplugged base station."""

    rate_hz = 1000.0

    def __init__(self):
        self.reads, self.closed = 0, False

    def read(self, timeout_s=0.1):
        from device.errors import DeviceError

        self.reads += 1
        if self.reads > 6:
            raise DeviceError("the base station closed the connection")
        t = (self.reads - 1) * 0.05 + np.arange(50) / self.rate_hz
        return 1000.0 + t, np.full((50, 2), 1e-4) * self.reads

    def close(self):
        self.closed = True


def test_record_ends_at_once_when_its_source_stops_keeping_what_came(tmp_path, capsys,
                                                                   monkeypatch):
    """The source failed after 0.3 s, yet the patient was told to go on contracting for
    the whole --seconds and the command exited 0 with a warning at the end."""
    import app.cli.emg as emg_cli

    source = _EndingSource()
    monkeypatch.setattr(emg_cli, "_open_source", lambda args: (source, "trigno:test"))
    out_file = tmp_path / "mvc.csv"
    code, out, err = run(["emg", "record", "trigno:test", "--seconds", "3", "--output",
                          str(out_file), "--muscle", "biceps", "--rest", "0"], capsys)
    assert code == 1, err
    lines = out.splitlines()
    stopped = next(i for i, line in enumerate(lines) if line.startswith("the source stopped"))
    assert lines[stopped].endswith(" s of 3 s: the base station closed the connection; "
                                   "the recording ends here, with what came")
    assert lines[stopped + 1] == "Relax."  # said at once, before the rest of the 3 s
    assert "warning: the source stopped early" not in out
    assert source.closed
    assert read_emg_file(out_file).samples.shape == (300, 2)


class _LabelledSource:
    """An LSL stream as device.lsl.inlet gives it: labelled channels, a trigger channel
    left out (its note), the samples of a contraction file, then nothing."""

    notes = ("left out of the LSL stream named 'amp', not EMG: triggerStream, a trigger channel "
             "of event codes (unit 'code')",)

    def __init__(self, data, labels):
        self.rate_hz, self.labels, self.data, self.sent = data.rate_hz, labels, data, 0

    def read(self, timeout_s=0.1):
        import time

        k = self.sent
        if k >= self.data.t_s.size:
            time.sleep(min(timeout_s, 0.01))
            return np.empty(0), np.empty((0, len(self.labels)))
        self.sent = min(k + 500, self.data.t_s.size)
        return 1000.0 + np.arange(k, self.sent) / self.rate_hz, self.data.samples[k:self.sent]

    def close(self):
        pass


def _recorded_from_lsl(emg, labels, seconds, tmp_path, capsys, monkeypatch):
    """(the CSV written, what was printed) of `rehab emg record lsl:amp` for `seconds` from
    a stream of `emg`'s samples whose channels are labelled `labels`."""
    import app.cli.emg as emg_cli

    monkeypatch.setattr(emg_cli, "_open_source",
                        lambda args: (_LabelledSource(emg, labels), "lsl:amp"))
    out_file = tmp_path / "mvc.csv"
    code, out, err = run(["emg", "record", "lsl:amp", "--seconds", f"{seconds:g}", "--output",
                          str(out_file)], capsys)
    assert code == 0, err
    return out_file, out


def test_record_names_its_columns_by_the_stream_labels_and_mvc_picks_them(
        made, tmp_path, capsys, monkeypatch):
    """`rehab emg record` wrote EMG1…EMGn and dropped the stream's labels: a CSV column is
    picked by label now, and by EMG<k> (its place) as commands written before do."""
    path, channel = made[2]["biceps"]
    contraction = read_emg_file(path)
    labels = tuple(f"lead {name}" for name in contraction.names)
    out_file, out = _recorded_from_lsl(contraction, labels, 0.5, tmp_path, capsys,
                                       monkeypatch)
    assert "note: left out of the LSL stream named 'amp', not EMG: triggerStream" in out
    recorded = read_emg_file(out_file)
    assert recorded.names == labels
    column = contraction.names.index(channel)
    values = []
    for picked in (labels[column], f"EMG{column + 1}"):
        trial = shutil.copy(made[1], tmp_path / f"s{len(values)}.h5")
        code, out, err = run(["emg", "mvc", str(trial), "--contraction",
                              f"biceps={out_file}:{picked}"], capsys)
        assert code == 0, err
        values.append(read_emg(trial).mvc["biceps"]["value_V"])
    assert values[0] == values[1]
    assert read_emg(trial).mvc["biceps"]["channel"] == labels[column]


class _JitteredSource(_LabelledSource):
    """An LSL stream whose sender pushed one chunk 37 ms late (a stalled computer): its
    stamps jump ahead, then the next chunk's overlap it, as liblsl stamps chunks at their
    push. It never runs dry (the contraction's samples over again), so the recording ends
    at --seconds, not at a source that went quiet: a race of the two, which a whole check
    lost."""

    def read(self, timeout_s=0.1):
        import time

        time.sleep(0.002)
        k = self.sent
        self.sent = k + 500
        index = np.arange(k, self.sent)
        stamps = 1000.0 + index / self.rate_hz
        if k == 1000:
            stamps = stamps + 0.037
        return stamps, self.data.samples[index % self.data.t_s.size]


def test_a_recording_whose_stamps_jitter_is_read_back_by_emg_mvc(made, tmp_path, capsys,
                                                                monkeypatch):
    """`rehab emg record lsl:…` wrote the stream's stamps as its time column; a chunk pushed
    late made a 37 ms jump, and `rehab emg mvc` refused the console's own recording ('a gap
    of 0.037126 s after sample 11286')."""
    import app.cli.emg as emg_cli

    path, channel = made[2]["biceps"]
    contraction = read_emg_file(path)
    source = _JitteredSource(contraction, contraction.names)
    monkeypatch.setattr(emg_cli, "_open_source", lambda args: (source, "lsl:amp"))
    out_file = tmp_path / "mvc.csv"
    code, _, err = run(["emg", "record", "lsl:amp", "--seconds", "1", "--output",
                          str(out_file), "--muscle", "biceps", "--rest", "0", "--channel",
                          str(contraction.names.index(channel) + 1)], capsys)
    assert code == 0, err
    recorded = read_emg_file(out_file)
    n = recorded.t_s.size
    assert n > 1500
    np.testing.assert_allclose(recorded.t_s, np.arange(n) / contraction.rate_hz, atol=1e-6)
    np.testing.assert_array_equal(recorded.samples,
                                  contraction.samples[np.arange(n) % contraction.t_s.size])
    trial = shutil.copy(made[1], tmp_path / "s.h5")
    code, _, err = run(["emg", "mvc", str(trial), "--contraction",
                        f"biceps={out_file}:{channel}"], capsys)
    assert code == 0, err


def test_record_keeps_emg_numbers_for_labels_a_csv_cannot_hold(tmp_path, capsys,
                                                              monkeypatch):
    data = read_emg_file(DATA / "plain.csv")
    labels = ("biceps, long head", *(f"m{k}" for k in range(1, len(data.names))))
    out_file, out = _recorded_from_lsl(data, labels, 0.3, tmp_path, capsys, monkeypatch)
    assert "note: the source's channel name 'biceps, long head' cannot be a CSV column" in out
    assert read_emg_file(out_file).names == tuple(f"EMG{k + 1}" for k in range(len(labels)))


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


def test_emg_streams_sends_liblsl_errors_to_the_data_folder_logs_never_making_one(
        data, monkeypatch, capsys):
    """liblsl's 'Stream transmission broke off' lines went to stderr under the command's
    own; with a data folder they go to its logs (device.lsl.library.log_liblsl_into)."""
    from device.lsl import library

    monkeypatch.setattr(library, "_log_file", [])
    monkeypatch.setattr(library, "find_streams", lambda wait_s: [])
    code, out, _ = run(["emg", "streams", "--wait", "0.1"], capsys)
    assert code == 0, out
    assert library._log_file == []  # no data folder: none made, liblsl keeps stderr
    assert not data.exists()
    data.mkdir(mode=0o700)
    code, _, _ = run(["emg", "streams", "--wait", "0.1"], capsys)
    assert code == 0
    assert library._log_file == [data / "logs" / library.LIBLSL_LOG]


def test_record_of_microvolts_read_as_volts_writes_nothing_and_says_why(tmp_path, capsys,
                                                                       monkeypatch):
    """`rehab emg record lsl:amp@V` of a µV stream wrote the CSV and said 'MVC 69428193 µV,
    held 2.56 s: ok'; the CSV was then refused by `rehab emg mvc`."""
    import types

    import app.cli.emg as emg_cli

    plain = read_emg_file(DATA / "plain.csv")
    data = types.SimpleNamespace(rate_hz=plain.rate_hz, t_s=plain.t_s,
                                 samples=plain.samples * 1e6)
    labels = tuple(plain.names)
    monkeypatch.setattr(emg_cli, "_open_source",
                        lambda args: (_LabelledSource(data, labels), "lsl:amp"))
    out_file = tmp_path / "mvc.csv"
    code, _, err = run(["emg", "record", "lsl:amp@V", "--muscle", "biceps", "--rest", "0",
                        "--seconds", "0.3", "--output", str(out_file)], capsys)
    assert code == 2
    assert not out_file.exists()
    assert err.count("\n") == 1
    assert "nothing written: biceps reaches" in err
    assert "(in volts as lsl:amp@V gives them)" in err


def test_emg_streams_says_which_stream_has_no_regular_rate(monkeypatch, capsys):
    """A marker stream (the console's own rehab-robot-events) was listed 'at 0 Hz'."""
    import types

    from device.lsl import library

    seen = [types.SimpleNamespace(name=name, type=kind, channel_count=1, nominal_rate_hz=rate,
                                  hostname="vm", source_id="s") for name, kind, rate in
            (("amp", "EMG", 2000.0), ("rehab-robot-events", "Markers", 0.0))]
    monkeypatch.setattr(library, "find_streams", lambda wait_s: seen)
    code, out, _ = run(["emg", "streams", "--wait", "0.1"], capsys)
    assert code == 0
    assert "'amp' type 'EMG': 1 channels at 2000 Hz from vm (s)" in out
    assert ("'rehab-robot-events' type 'Markers': 1 channels at no regular rate (markers, "
            "not EMG) from vm (s)") in out
    assert " at 0 Hz" not in out


class _RestingSource:
    """A muscle that never contracts (an electrode off the skin, a patient who did not
    push): 15 µV of noise at 2 kHz, as long as it is read, its stamps its own."""

    rate_hz = 2000.0

    def __init__(self):
        self.rng, self.sent = np.random.default_rng(5), 0

    def read(self, timeout_s=0.1):
        import time

        time.sleep(0.002)
        k = self.sent
        self.sent += 100
        return 1000.0 + np.arange(k, self.sent) / self.rate_hz, \
            self.rng.normal(0.0, 15e-6, (100, 1))

    def close(self):
        pass


def test_a_guided_mvc_with_no_effort_above_the_rest_is_flagged(tmp_path, capsys, monkeypatch):
    """`rehab emg record --muscle biceps` on resting noise said 'MVC 15 µV, held 8.56 s: ok'
    (hR). It now records a rest first (not written to the CSV) and the push must rise
    above it."""
    import app.cli.emg as emg_cli

    monkeypatch.setattr(emg_cli, "_open_source", lambda args: (_RestingSource(), "lsl:amp"))
    out_file = tmp_path / "mvc.csv"
    code, out, err = run(["emg", "record", "lsl:amp", "--muscle", "biceps", "--rest", "1",
                          "--seconds", "1.5", "--output", str(out_file)], capsys)
    assert code == 0, err
    lines = out.splitlines()
    assert lines.index("Rest, relaxed (1 s) …") < next(
        i for i, line in enumerate(lines) if line.startswith("Contract the biceps"))
    assert "FLAGGED: no_effort_above_rest" in out
    assert "warning: biceps: no effort above rest" in out
    # the CSV holds the contraction only: its first time is 0, its samples after the rest's
    assert read_emg_file(out_file).t_s[0] == 0.0
    code, _, err = run(["emg", "record", "lsl:amp", "--muscle", "biceps", "--rest", "-1",
                        "--output", str(tmp_path / "x.csv")], capsys)
    assert code == 2
    assert err.count("\n") == 1
    assert "--rest -1" in err
