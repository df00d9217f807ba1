"""EMG in a trial: import on the trial's clock, the session's MVC and its quality check,
the % MVC envelopes on the ticks, and synthetic subjects driven by virtual patients whose
activations the processing recovers."""

import shutil

import h5py
import numpy as np
import pytest

from app.emg.importing import EmgImportError, import_emg_file, trial_time_from_monotonic
from app.emg.session import Contraction, session_mvc, trial_envelopes
from app.emg.subjects import Subject, record_trial, write_contractions
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.emg.mvc import BELOW_TRIAL
from core.emg.processing import rms_envelope
from core.emg.synthetic import MUSCLES, emg_from_excitations
from core.trial import THESIS_SUBJECT
from device.emg.files import write_plain_csv
from device.errors import RecordingError
from device.recording.emgfile import read_emg
from tests.trialfiles import as_crashed, edited

SHORT = THESIS_SUBJECT.replace(repetitions=1, assistance_level=0.0)


@pytest.fixture(scope="module")
def plain_trial(tmp_path_factory):
    path = tmp_path_factory.mktemp("trial") / "trial.h5"
    save(simulate(SHORT, patient="healthy", engine="python"), path)
    return path


@pytest.fixture
def trial(plain_trial, tmp_path):
    return shutil.copy(plain_trial, tmp_path / "trial.h5")


@pytest.fixture(scope="module")
def subject_trial(tmp_path_factory):
    folder = tmp_path_factory.mktemp("subject")
    subject = Subject.drawn(2, muscles=MUSCLES)
    return record_trial(folder / "s2.h5", subject, seed=3, engine="python"), folder


def _emg_file(path, duration_s, rate_hz=2000.0, seed=0):
    t = np.arange(0.0, duration_s, 0.002)
    u = np.full((t.size, 4), 0.1)
    te, emg = emg_from_excitations(u, 0.002, seed=seed)
    return write_plain_csv(path, ("biceps", "triceps", "anterior_deltoid"), te, emg[:, :3])


def test_an_imported_file_lands_on_the_trials_clock(trial, tmp_path):
    duration = read_trial(trial).n_samples * 0.002
    done = import_emg_file(trial, _emg_file(tmp_path / "emg.csv", duration - 1.0), offset_s=0.5,
                           muscles=["biceps", "triceps", "anterior_deltoid"])
    assert done.muscles == ("biceps", "triceps", "anterior_deltoid")
    assert done.first_s == pytest.approx(0.5)
    assert any("covers" in n for n in done.notes)
    emg = read_emg(trial)
    assert emg.notes == done.notes
    assert emg.rate_hz == pytest.approx(1925.926, rel=1e-6)
    assert emg.time_s[0] == pytest.approx(0.5)
    assert emg.samples.shape == (emg.time_s.size, 3)
    assert emg.attrs["offset_s"] == 0.5
    assert "offset" in emg.attrs["clock"]
    with h5py.File(trial, "r") as f:  # plain h5py, as docs/data-format.md shows
        assert f["emg/samples"].attrs["units"] == "V"
        assert f["emg"].attrs["sampling_rate_hz"] == pytest.approx(1925.926, rel=1e-6)
        assert f["emg/samples"].fletcher32
        assert next(r["muscle"].decode() for r in f["emg/channels"][()]) == "biceps"
    # the trial's own samples are untouched and it still reads
    assert read_trial(trial).status == "complete"


def test_import_refuses_what_it_should(trial, tmp_path):
    emg = _emg_file(tmp_path / "emg.csv", 2.0)
    import_emg_file(trial, emg)
    with pytest.raises(RecordingError, match="already has EMG"):
        import_emg_file(trial, emg)
    import_emg_file(trial, emg, replace=True)
    with pytest.raises(EmgImportError, match="2 muscles given for 3 EMG channels"):
        import_emg_file(trial, emg, muscles=["a", "b"], replace=True)
    with pytest.raises(EmgImportError, match="named twice"):
        import_emg_file(trial, emg, muscles=["a", "a", "b"], replace=True)
    as_crashed(trial)
    with pytest.raises(EmgImportError, match="still being recorded"):
        import_emg_file(trial, emg, replace=True)


def test_monotonic_stamps_map_through_the_trials_wall_time(trial):
    data = read_trial(trial)
    with pytest.raises(EmgImportError, match="wall_time_origin_monotonic_s"):
        trial_time_from_monotonic(data, [1.0])
    origin = 1234.5
    with edited(trial) as f:
        f["summary"].attrs["wall_time_origin_monotonic_s"] = origin
        # a late stretch: wall time runs 10 ms ahead of the nominal time after sample 1000
        wall = f["timeseries/wall_time"][()]
        wall[1000:] += 0.010
        f["timeseries/wall_time"][...] = wall
    data = read_trial(trial)
    t = data.time
    mapped = trial_time_from_monotonic(data, origin + np.array([wall[500], wall[1500],
                                                                wall[0] - 1.0, wall[-1] + 1.0]))
    np.testing.assert_allclose(mapped, [t[500], t[1500], t[0] - 1.0, t[-1] + 1.0], atol=1e-9)


def test_a_synthetic_subject_is_recovered_through_the_trial_file(subject_trial):
    """A virtual patient's torques → muscles → EMG in the trial file → MVC → % MVC on the
    ticks ≈ the excitations behind it."""
    synthetic, folder = subject_trial
    path = shutil.copy(synthetic.path, folder / "copy.h5")
    contractions = write_contractions(folder, synthetic.subject, session=1)
    mvcs = session_mvc([path], [Contraction(m, p, ch) for m, (p, ch) in contractions.items()],
                       full_scale_V=synthetic.subject.electrodes.full_scale_V)
    assert all(m.ok for m in mvcs), [m.reasons for m in mvcs]
    env = trial_envelopes(path)
    assert env.muscles == MUSCLES
    assert env.values.shape == (synthetic.time_s.size, 4)
    truth = rms_envelope(synthetic.excitation, 500.0)
    truth_on_ticks = np.column_stack([np.interp(synthetic.time_s, truth.t_s, truth.values[:, i])
                                      for i in range(4)])
    good = np.isfinite(env.values).all(axis=1)
    assert good.mean() > 0.95
    active = [i for i in range(4) if truth_on_ticks[good, i].std() > 0.01]
    assert len(active) >= 3  # the reach moves both joints both ways
    for i in active:
        r, s = env.values[good, i], truth_on_ticks[good, i]
        assert np.corrcoef(r, s)[0, 1] > 0.9, MUSCLES[i]
        assert np.sqrt(np.mean((r - s) ** 2)) < 0.05, MUSCLES[i]


def test_a_bad_mvc_is_flagged_against_the_trial_subject_2(tmp_path):
    """The thesis's subject 2: the deltoid's MVC effort was far from maximal, so the reach
    reads as most of an MVC; the check against the trial flags exactly that muscle."""
    subject = Subject.drawn(2, bad_mvc={"anterior_deltoid": 0.08})
    synthetic = record_trial(tmp_path / "s2.h5", subject, seed=1, engine="python")
    contractions = write_contractions(tmp_path, subject, session=1)
    mvcs = session_mvc([synthetic.path],
                       [Contraction(m, p, ch) for m, (p, ch) in contractions.items()])
    flagged = {m.muscle: m.flags for m in mvcs}
    assert flagged["anterior_deltoid"] == (BELOW_TRIAL,)
    assert flagged["biceps"] == ()
    assert flagged["triceps"] == ()
    stored = read_emg(synthetic.path).mvc["anterior_deltoid"]
    assert stored["flags"] == [BELOW_TRIAL]
    assert trial_envelopes(synthetic.path).flags["anterior_deltoid"] == (BELOW_TRIAL,)


def test_envelopes_and_mvc_refuse_a_trial_without_what_they_need(trial, tmp_path):
    with pytest.raises(EmgImportError, match="has no EMG"):
        trial_envelopes(trial)
    import_emg_file(trial, _emg_file(tmp_path / "emg.csv", 2.0))
    with pytest.raises(EmgImportError, match="no MVC for biceps"):
        trial_envelopes(trial)
    contraction = _emg_file(tmp_path / "mvc.csv", 4.0, seed=5)
    with pytest.raises(EmgImportError, match="no trial has the muscle 'pectoralis'"):
        session_mvc([trial], [Contraction("pectoralis", contraction)])
    with pytest.raises(EmgImportError, match="has no channel 'EMG9'"):
        session_mvc([trial], [Contraction("biceps", contraction, "EMG9")])
    with pytest.raises(EmgImportError, match="no trial given"):
        session_mvc([], [Contraction("biceps", contraction)])
