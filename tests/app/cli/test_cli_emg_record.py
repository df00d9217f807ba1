"""`rehab emg record`: a guided MVC from a live source (the fake Trigno Control Utility,
a source that stops, resting noise): the prompts, the channel and muscle refused before
the patient is told to contract, the CSV and the MVC's check."""

from pathlib import Path

import numpy as np
import pytest

from device.emg.files import read_emg_file
from tests.app.cli.running import run
from tests.fake_trigno import fake_trigno

DATA = Path(__file__).parents[2] / "data" / "emg"


pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


def test_record_a_guided_mvc_from_the_fake_trigno(tmp_path, capsys):
    fake = fake_trigno()
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
    fake = fake_trigno()
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
