"""Issue 28 #13: a trial's `/emg` edited by hand is refused by every reader, `rehab emg show`
included, in one line; before, `emg show` accepted 5 columns for 3 channels, time going
backwards or NaN, and an MVC's flags stored as text (shown split into letters)."""

from __future__ import annotations

import shutil

import h5py
import pytest

from app.emg.session import Contraction, session_mvc, trial_envelopes
from app.emg.subjects import Subject, record_trial, write_contractions
from app.errors import AppError
from device.errors import DeviceError
from device.recording.emgfile import read_emg
from tests.app.cli.running import run
from tests.corruption import TRIAL_EDITS
from tests.trialfiles import edited

EDITS = {
    "emg 5 columns for 3": "/emg/samples holds float64 of shape",
    "emg time backwards": "/emg/time goes from",
    "emg time NaN": "/emg/time is nan at sample 7",
    "mvc flags text": "flags is 'saturated', not the JSON list",
    # what is wrong with the EMG, kept with it: dropped unsaid when not a list of texts
    "emg notes cut": "/emg notes is '[\"the capture ended e', not the JSON list",
    "emg notes object": "/emg notes is \"{'ended': 'early'}\", not the JSON list",
}


@pytest.fixture(scope="module")
def with_emg(tmp_path_factory):
    """A synthetic subject's trial with its EMG and the session's MVCs."""
    folder = tmp_path_factory.mktemp("emg")
    subject = Subject.drawn(2)
    path = record_trial(folder / "trial.h5", subject, seed=0).path
    contractions = write_contractions(folder, subject, session=1)
    session_mvc([path], [Contraction(m, p, ch) for m, (p, ch) in contractions.items()],
                full_scale_V=subject.electrodes.full_scale_V)
    return path


@pytest.mark.parametrize("reseal", [False, True], ids=["edited", "edited and sealed again"])
@pytest.mark.parametrize("edit", EDITS)
def test_an_edited_emg_group_is_refused_by_every_reader(with_emg, tmp_path, capsys, edit,
                                                        reseal):
    path = shutil.copy(with_emg, tmp_path / "trial.h5")
    assert trial_envelopes(path).values.shape[1] == 3  # the original reads
    with (edited(path) if reseal else h5py.File(path, "r+")) as f:
        TRIAL_EDITS[edit](f, path)
    with pytest.raises(DeviceError) as caught:
        read_emg(path)
    text = str(caught.value)
    assert str(path) in text
    assert "\n" not in text
    assert EDITS[edit] in text or (not reseal and "does not match its seal" in text)
    with pytest.raises((AppError, DeviceError)):
        trial_envelopes(path)
    code, out, err = run(["emg", "show", str(path)], capsys)
    assert code == 2
    assert err.count("\n") == 1
    assert "FLAGGED" not in out


@pytest.mark.parametrize(("stored", "said"), [
    ('[[0.5, 1000.0], [0.2, 1000.004]]', "[[0.5, 1000.0], [0.2, 1000.004]]"),
    ('[[0.5, "1000"]]', "[[0.5, '1000']]"),
    ('[[0.5, NaN]]', "[[0.5, nan]]"),
    ('[[0.5, 1000.0]', "[[0.5, 1000.0]"),
], ids=["out of order", "text", "NaN", "cut"])
def test_clock_offsets_that_are_not_the_console_s_are_refused(with_emg, tmp_path, stored,
                                                              said):
    """The clock offsets an LSL capture added to the sender's stamps (/emg clock_offsets)
    are what says how its times were made: an edit that the file's seal was made again
    over is refused as the other /emg edits are, not read as some other offsets."""
    path = shutil.copy(with_emg, tmp_path / "trial.h5")
    with edited(path) as f:
        f["emg"].attrs["clock_offsets"] = stored
    with pytest.raises(DeviceError, match="/emg clock_offsets is ") as caught:
        read_emg(path)
    assert said[:40] in str(caught.value)
    with edited(path) as f:  # as the console writes them, they read
        f["emg"].attrs["clock_offsets"] = "[[0.5, 1000.0], [2.5, 1000.004]]"
    assert read_emg(path).clock_offsets == ((0.5, 1000.0), (2.5, 1000.004))
