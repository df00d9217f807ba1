"""`rehab emg record lsl:…`: a recording from an LSL stream keeps its channel labels as its
columns, one sample a period whatever its stamps' jitter, and writes nothing of µV read as
volts; `rehab emg mvc` reads it back."""

import shutil
from pathlib import Path

import numpy as np
import pytest

from app.emg.subjects import Subject, record_trial, write_contractions
from device.emg.files import read_emg_file
from device.recording.emgfile import read_emg
from tests.app.cli.running import run

DATA = Path(__file__).parents[2] / "data" / "emg"


pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


@pytest.fixture(scope="module")
def synthetic(tmp_path_factory):
    """A synthetic subject's trial and its MVC contraction files."""
    folder = tmp_path_factory.mktemp("emg")
    subject = Subject.drawn(1)
    trial = record_trial(folder / "synthetic.h5", subject, seed=0, engine="python")
    return trial.path, write_contractions(folder, subject, session=1)


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
        synthetic, tmp_path, capsys, monkeypatch):
    """`rehab emg record` wrote EMG1…EMGn and dropped the stream's labels: a CSV column is
    picked by label now, and by EMG<k> (its place) as commands written before do."""
    path, channel = synthetic[1]["biceps"]
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
        trial = shutil.copy(synthetic[0], tmp_path / f"s{len(values)}.h5")
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


def test_a_recording_whose_stamps_jitter_is_read_back_by_emg_mvc(synthetic, tmp_path, capsys,
                                                                monkeypatch):
    """`rehab emg record lsl:…` wrote the stream's stamps as its time column; a chunk pushed
    late made a 37 ms jump, and `rehab emg mvc` refused the console's own recording ('a gap
    of 0.037126 s after sample 11286')."""
    import app.cli.emg as emg_cli

    path, channel = synthetic[1]["biceps"]
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
    trial = shutil.copy(synthetic[0], tmp_path / "s.h5")
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
