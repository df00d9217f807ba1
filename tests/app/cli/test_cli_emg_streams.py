"""`rehab emg streams`: the Lab Streaming Layer's streams, and liblsl's errors into the
data folder's logs."""

from pathlib import Path

import pytest

from tests.app.cli.running import run

DATA = Path(__file__).parents[2] / "data" / "emg"


pytestmark = pytest.mark.usefixtures("data")  # the folders of tests/app/cli/conftest.py


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
