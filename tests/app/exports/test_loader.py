"""The researcher's loader: trials as named arrays, studies as tables, and damaged files."""

from __future__ import annotations

import inspect
import json
import shutil
import textwrap
from pathlib import Path

import h5py
import numpy as np
import pytest

import app.exports.loader as data_module
from app.errors import AppError, TrialFileError
from app.exports.loader import Study, Trial, load_study, load_trial, read_info
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT, TrialParameters
from device.loop.pipeline import PHASE_EXERCISE
from tests.trialfiles import as_crashed

D = THESIS_SUBJECT.replace(repetitions=1)
CIRCLE = D.replace(shape="circle", radius_m=0.07)


def make_trial(path: Path, parameters: TrialParameters = D, seed: int = 0,
               code: str = "SIM") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    save(simulate(parameters, patient="healthy", seed=seed), path, subject_code=code)
    return path


@pytest.fixture(scope="module")
def trial_path(tmp_path_factory) -> Path:
    return make_trial(tmp_path_factory.mktemp("trial") / "trial.h5", CIRCLE, seed=3)


@pytest.fixture(scope="module")
def study_folder(tmp_path_factory) -> Path:
    """Three sound trials in two subfolders, and three files that are not trials."""
    folder = tmp_path_factory.mktemp("study")
    make_trial(folder / "a" / "one.h5", D, seed=1, code="S01")
    make_trial(folder / "a" / "two.h5", CIRCLE, seed=2, code="S01")
    make_trial(folder / "b" / "three.h5", D, seed=3, code="S02")
    (folder / "b" / "garbage.h5").write_bytes(b"this is not HDF5 at all" * 10)
    (folder / "b" / "empty.h5").write_bytes(b"")
    with h5py.File(folder / "other.h5", "w") as f:
        f["x"] = np.arange(3)
    return folder


# -- one trial ------------------------------------------------------------------


def test_every_channel_and_all_metadata_equal_the_hdf5_file(trial_path):
    trial = load_trial(trial_path)
    with h5py.File(trial_path, "r") as f:
        order = [row["name"].decode() for row in f["channels"][()]]
        assert trial.names == tuple(order) == tuple(trial)
        assert len(trial) == len(order)
        for name in order:
            dataset = f["timeseries"][name]
            assert trial[name].dtype == dataset.dtype
            np.testing.assert_array_equal(trial[name], dataset[()])
            assert trial.units[name] == dataset.attrs["units"]
            assert trial.frames[name] == dataset.attrs["frame"]
            assert trial.descriptions[name] == dataset.attrs["description"]
        stored = json.loads(f.attrs["parameters"])
        assert dict(trial.parameter_values) == stored
        assert trial.parameters == TrialParameters.from_dict(stored)
        assert trial.subject.to_dict() == json.loads(f.attrs["subject"])
        # assert_equal: NaN (an undefined metric) equals NaN
        np.testing.assert_equal(dict(trial.metrics),
                                {k: float(v) for k, v in f["metrics"].attrs.items()})
        assert trial.status == f.attrs["status"] == "complete"
        assert trial.sample_period_s == f.attrs["sample_period_s"]
        assert [e["kind"] for e in trial.events] == [
            row["kind"].decode() for row in f["events"][()]]
    assert trial.n_samples == trial["time"].shape[0]
    assert trial.time is trial["time"]
    assert trial.task == "circle"
    assert trial.sampling_frequency_hz == pytest.approx(500.0)
    assert trial.recorded_s == pytest.approx(trial.n_samples * 0.002)
    assert trial.events_of("start")[0]["tick"] == 0
    assert trial.notes == ()


def test_arrays_are_read_only_and_missing_channels_are_named(trial_path):
    trial = load_trial(trial_path)
    with pytest.raises(ValueError, match="read-only"):
        trial["position"][0, 0] = 1.0
    with pytest.raises(TypeError):
        trial.arrays["position"] = np.zeros(3)
    with pytest.raises(KeyError, match=r"no channel 'emg'.*position"):
        trial["emg"]
    assert "position" in trial
    assert "emg" not in trial


def test_exercise_mask_and_exercise_only_channels(trial_path):
    trial = load_trial(trial_path)
    mask = trial.exercise
    np.testing.assert_array_equal(mask, trial["phase"] == PHASE_EXERCISE)
    assert 0 < mask.sum() < trial.n_samples  # the simulator holds at the end
    np.testing.assert_array_equal(trial.channel("position", exercise_only=True),
                                  trial["position"][mask])
    assert trial.channel("position") is trial["position"]


def test_flat_table_names_every_component_by_its_frame(trial_path):
    trial = load_trial(trial_path)
    table = trial.table()
    widths = sum(1 if v.ndim == 1 else v.shape[1] for v in trial.arrays.values())
    assert len(table) == widths
    np.testing.assert_array_equal(table["position_y_m"], trial["position"][:, 1])
    np.testing.assert_array_equal(table["subject_angle_isb_elbow_rad"],
                                  trial["subject_angle_isb"][:, 1])
    np.testing.assert_array_equal(table["robot_angle_2_rad"], trial["robot_angle"][:, 1])
    np.testing.assert_array_equal(table["force_sensor_z_N"], trial["force_sensor"][:, 2])
    np.testing.assert_array_equal(table["tick"], trial["tick"])
    assert trial.components("force_sensor") == ("x", "y", "z")
    assert trial.components("subject_torque") == ("shoulder", "elbow")
    exercise = trial.table(exercise_only=True)
    assert exercise["time_s"].shape == (trial.exercise.sum(),)


def test_quick_metadata_equals_the_full_read(trial_path):
    info = read_info(trial_path)
    trial = load_trial(trial_path)
    assert not isinstance(info, Trial)
    np.testing.assert_equal(info.row(), trial.row())
    assert info.n_samples == trial.n_samples
    assert info.parameters == trial.parameters


def test_a_file_left_open_by_a_crash_is_read_through_the_full_reader(trial_path, tmp_path):
    copy = tmp_path / "crashed.h5"
    shutil.copy(trial_path, copy)
    as_crashed(copy)
    info = read_info(copy)
    assert info.status == "recording"
    assert any("not closed" in note for note in info.notes)
    assert info.n_samples == load_trial(trial_path).n_samples


def test_damaged_file_raises_the_readers_error(tmp_path):
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"\x00" * 100)
    with pytest.raises(TrialFileError, match="not an HDF5 file"):
        read_info(bad)
    with pytest.raises(TrialFileError, match="not an HDF5 file"):
        load_trial(bad)


# -- a study --------------------------------------------------------------------


def test_study_keeps_going_past_unreadable_files_and_says_why(study_folder):
    fractions = []
    study = load_study(study_folder, progress=fractions.append)
    assert isinstance(study, Study)
    assert [info.path.name for info in study.infos] == ["one.h5", "two.h5", "three.h5"]
    assert len(study) == 3
    reasons = {failure.path.name: failure.reason for failure in study.failed}
    assert set(reasons) == {"garbage.h5", "empty.h5", "other.h5"}
    assert "not an HDF5 file" in reasons["garbage.h5"]
    assert "empty" in reasons["empty.h5"]
    assert "not a rehab-console trial file" in reasons["other.h5"]
    assert fractions[-1] == 1.0
    assert len(fractions) == 6
    # at the prompt: a few words, not every row (about 100,000 characters before)
    shown = repr(study)
    assert "3 trial(s) of 2 patient(s), 3 file(s) not read (.failed)" in shown
    assert len(shown) < 400


def test_study_table_has_one_row_per_trial_with_parameters_and_metrics(study_folder):
    study = load_study(study_folder)
    assert [row["file"] for row in study.rows] == ["a/one.h5", "a/two.h5", "b/three.h5"]
    assert list(study.column("subject_code")) == ["S01", "S01", "S02"]
    assert list(study.column("parameter_shape")) == ["d", "circle", "d"]
    np.testing.assert_array_equal(study.column("parameter_centre_x_m"), [-0.3, -0.3, -0.3])
    rmse = study.column("metric_rmse_x_m")
    assert rmse.dtype == np.float64
    assert np.isfinite(rmse).all()
    assert study.column("n_samples").dtype == np.int64
    assert study.column("parameter_clockwise").dtype == bool
    for row, trial in zip(study.rows, study, strict=True):
        assert isinstance(trial, Trial)
        assert row["metric_rmse_x_m"] == trial.metrics["rmse_x_m"]
        assert row["n_samples"] == trial.n_samples
    table = study.table()
    assert set(table) == set(study.columns)
    assert "metric_duration_s" in table
    assert "parameter_duration_s" in table
    with pytest.raises(KeyError, match="no column 'metric_nothing'"):
        study.column("metric_nothing")


def test_study_filter_and_pattern(study_folder):
    study = load_study(study_folder)
    circles = study.where(lambda row: row["parameter_shape"] == "circle")
    assert [p.name for p in circles.paths] == ["two.h5"]
    assert circles.failed == study.failed
    only_a = load_study(study_folder, pattern="a/*.h5")
    assert len(only_a) == 2
    assert only_a.failed == ()


def test_missing_study_folder_is_refused(tmp_path):
    with pytest.raises(AppError, match="does not exist"):
        load_study(tmp_path / "nowhere")


def test_module_example_runs(tmp_path, monkeypatch, capsys):
    make_trial(tmp_path / "trial.h5", D, seed=4)
    make_trial(tmp_path / "study" / "p1" / "circle.h5", CIRCLE, seed=5)
    make_trial(tmp_path / "study" / "p1" / "d.h5", D, seed=6)
    (tmp_path / "study" / "broken.h5").write_bytes(b"not a trial")
    doc = inspect.getdoc(data_module)
    block = doc.split("::\n", 1)[1].split("\n\n`Trial`", 1)[0]
    monkeypatch.chdir(tmp_path)
    exec(compile(textwrap.dedent(block), "app/exports/loader.py (example)", "exec"), {})
    out = capsys.readouterr().out
    assert "broken.h5" in out
    assert "not an HDF5 file" in out
    assert "circle.h5" in out
    assert "d.h5" not in out.replace("broken.h5", "")


@pytest.mark.parametrize("damage", ["timeseries_is_a_dataset", "channel_is_a_group"])
def test_one_file_with_a_damaged_layout_lands_in_failed_and_the_study_goes_on(
        trial_path, tmp_path, damage):
    folder = tmp_path / "study"
    folder.mkdir()
    shutil.copy(trial_path, folder / "good.h5")
    bad = folder / "bad.h5"
    shutil.copy(trial_path, bad)
    with h5py.File(bad, "r+") as f:
        if damage == "timeseries_is_a_dataset":
            del f["timeseries"]
            f.create_dataset("timeseries", data=[1, 2, 3])
        else:
            del f["timeseries/time"]
            f["timeseries"].create_group("time")
    study = load_study(folder)
    assert [info.path.name for info in study.infos] == ["good.h5"]
    assert [failure.path.name for failure in study.failed] == ["bad.h5"]
    assert study.failed[0].reason  # with its reason
