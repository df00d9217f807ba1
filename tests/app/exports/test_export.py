"""Exports: CSV/TSV, .mat and BIDS read back equal to the trial file; names never leak;
nothing is overwritten unasked; batches keep going and report progress."""

from __future__ import annotations

import csv
import errno
import json
import math
import re
import struct
import zlib
from pathlib import Path

import numpy as np
import pytest
import scipy.io

import app.exports.files as export_files_module
from app.errors import AppError
from app.exports.bids_channels import CHANNEL_TYPES, bids_units
from app.exports.columns import components, format_values, table_columns, unit_suffix
from app.exports.loader import load_trial
from app.exports.mat import matlab_name
from app.exports.run import (
    ExportError,
    OutputExistsError,
    TrialSource,
    export_folder,
    export_patient,
    export_patients,
    export_trial,
    export_trials,
)
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.headless import simulate
from core.trial import THESIS_SUBJECT
from device.recording.record import GLOBAL, JOINTS
from device.recording.trialfile import SubjectInfo, write_trial

D = THESIS_SUBJECT.replace(repetitions=1)
FIRST, LAST = "Zebulon", "Quaxworth"  # distinctive: no channel, unit or word contains them
BIDS_RUN = re.compile(
    r"sub-(?P<sub>[A-Za-z0-9]+)_ses-(?P<ses>\d+)_task-(?P<task>[A-Za-z0-9]+)"
    r"_tracksys-(?P<sys>[A-Za-z0-9]+)_run-(?P<run>\d+)_(?P<suffix>motion|channels|events)"
    r"\.(tsv|json)"
)
MOTION_REQUIRED_COLUMNS = ["name", "component", "type", "tracked_point", "units"]
COMPONENTS = {"x", "y", "z", "quat_x", "quat_y", "quat_z", "quat_w", "n/a"}


def write(path: Path, parameters=D, seed: int = 0, code: str = "SIM", spoil: bool = False
          ) -> Path:
    """A simulated trial file; `spoil` puts NaN and ±inf in a few values."""
    run = simulate(parameters, patient="healthy", seed=seed)
    records = run.records.copy()
    if spoil:
        records["position"][5, 0] = np.nan
        records["force"][6, 1] = np.inf
        records["force"][7, 0] = -np.inf
        records["lateness"][8] = np.nan
    path.parent.mkdir(parents=True, exist_ok=True)
    return write_trial(
        path, records, parameters=parameters,
        subject=SubjectInfo.from_parameters(code, parameters), robot=run.plan.robot,
        backend=f"simulator ({run.patient}, seed {seed})", sample_period_s=run.plan.period_s,
        events=[*run.events, {"time_s": 1.0, "tick": 500, "kind": "mark",
                              "message": "therapist's mark, with \"quotes\"\tand a tab",
                              "values": {"note": "a, b"}}],
        status=run.status, metrics={"rmse_x_m": 0.001, "sparc": -2.5, "reach_sparc": math.nan},
    )


@pytest.fixture(scope="module")
def trial_file(tmp_path_factory) -> Path:
    return write(tmp_path_factory.mktemp("source") / "T1.h5", seed=2, spoil=True)


@pytest.fixture(scope="module")
def trial(trial_file):
    return load_trial(trial_file)


@pytest.fixture(scope="module")
def registry(tmp_path_factory) -> tuple[Registry, str]:
    """A patient with a distinctive name and three trials in two sessions (exports only
    read it)."""
    registry = Registry(DataDir(tmp_path_factory.mktemp("registry") / "data"))
    patient = registry.create_patient(FIRST, LAST, side="left", body_mass_kg=70.0,
                                      notes=f"{FIRST} {LAST} prefers mornings")
    for seed, session in ((0, 1), (1, 1), (2, 2)):
        begun = registry.begin_trial(patient.code, D, backend="simulator",
                                     session_number=session, patient_kind="healthy",
                                     therapist=f"{LAST} senior")
        write(begun.path, seed=seed, code=patient.code)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.001})
    return registry, patient.code


def read_rows(path: Path, delimiter: str) -> list[list[str]]:
    with path.open(encoding="utf-8", newline="") as stream:
        return list(csv.reader(stream, delimiter=delimiter))


def as_float(text: str) -> float:
    return math.nan if text in ("NaN", "n/a") else float(text)


def assert_text_equals(texts: list[str], values: np.ndarray, rtol: float = 0.0) -> None:
    read = np.array([as_float(t) for t in texts])
    if rtol:
        np.testing.assert_allclose(read, values.astype(np.float64), rtol=rtol, atol=0.0)
    else:
        np.testing.assert_array_equal(read.astype(values.dtype), values)


# -- naming ----------------------------------------------------------------------


def test_components_and_unit_suffixes_follow_the_frame_and_units():
    assert components(GLOBAL, 2) == ("x", "y")
    assert components(JOINTS, 2) == ("1", "2")
    assert components("subject arm: (θ_s, θ_e) absolute, eq. 3.16 convention", 2) == (
        "shoulder", "elbow")
    assert components("a frame from a later instrument", 3) == ("1", "2", "3")
    assert components("none", 1) == ("",)
    assert unit_suffix("rad/s^2") == "rad_s2"
    assert unit_suffix("N*m") == "Nm"
    assert unit_suffix("1") == ""
    assert bids_units("N*m") == "N.m"
    assert bids_units("1") == "n/a"


@pytest.mark.parametrize("repeats", [1, 50])  # value by value, or each distinct value once
def test_values_are_written_exactly_with_missing_and_infinite_values_marked(repeats):
    values = np.tile([0.1, -0.0, 0.0, np.nan, np.inf, -np.inf, 1e-300, 2.0 / 3.0], repeats)
    texts = format_values(values)
    assert texts == ["0.1", "-0.0", "0.0", "NaN", "Inf", "-Inf", "1e-300",
                     "0.6666666666666666"] * repeats
    single = values.astype(np.float32)
    np.testing.assert_array_equal(np.array([as_float(t) for t in format_values(single)],
                                           dtype=np.float32), single)
    assert format_values(values, digits=3, missing="n/a")[:4] == ["0.1", "-0", "0", "n/a"]
    assert format_values(np.array([3, -1], dtype=np.int64)) == ["3", "-1"]


def test_column_names_carry_component_and_unit(trial):
    names = [c.name for c in table_columns(trial.arrays, trial.units, trial.frames,
                                           trial.descriptions)]
    for name in ("tick", "time_s", "phase", "position_x_m", "position_y_m",
                 "robot_angle_1_rad", "robot_acceleration_2_rad_s2", "torque_applied_2_Nm",
                 "velocity_desired_x_m_s", "force_sensor_z_N", "subject_angle_shoulder_rad",
                 "subject_angle_isb_elbow_rad", "direction_desired_y"):
        assert name in names
    assert len(names) == len(set(names))


def test_matlab_names_are_valid_identifiers_and_unique():
    taken: set[str] = set()
    made = [matlab_name(n, taken) for n in ("emg-1", "_hidden", "1st", "a" * 70, "a" * 70,
                                            "position")]
    assert made[:3] == ["emg_1", "x_hidden", "x1st"]
    assert made[-1] == "position"
    assert len(set(made)) == len(made)
    assert all(re.fullmatch(r"[A-Za-z][A-Za-z0-9_]{0,62}", m) for m in made)


# -- .mat ------------------------------------------------------------------------


def test_mat_reads_back_equal_to_the_hdf5(trial, tmp_path):
    (path,) = export_trial(trial, tmp_path, format="mat")
    assert path == tmp_path / "T1.mat"
    raw = path.read_bytes()
    assert raw.startswith(b"MATLAB 5.0 MAT-file")
    assert struct.unpack("<I", raw[128:132])[0] == 15  # miCOMPRESSED: compression is on
    mat = scipy.io.loadmat(path, squeeze_me=False)
    timeseries = mat["timeseries"][0, 0]
    assert list(timeseries.dtype.names) == list(trial.names)
    for name in trial.names:
        values = timeseries[name]
        expected = trial[name] if trial[name].ndim == 2 else trial[name].reshape(-1, 1)
        assert values.dtype == expected.dtype, name
        np.testing.assert_array_equal(values, expected)
    units, frames = mat["units"][0, 0], mat["frames"][0, 0]
    channels = mat["channels"][0, 0]
    assert [c[0] for c in channels["name"][:, 0]] == list(trial.names)
    for name in trial.names:
        assert units[name][0] == trial.units[name]
        assert frames[name][0] == trial.frames[name]
    parameters = mat["parameters"][0, 0]
    assert parameters["shape"][0] == trial.parameter_values["shape"]
    np.testing.assert_array_equal(parameters["centre_m"], [trial.parameter_values["centre_m"]])
    metrics = mat["metrics"][0, 0]
    assert set(metrics.dtype.names) == set(trial.metrics)
    for name, value in trial.metrics.items():
        np.testing.assert_equal(metrics[name][0, 0], value)
    events = mat["events"][0, 0]
    assert [k[0] for k in events["kind"][:, 0]] == [e["kind"] for e in trial.events]
    assert [json.loads(v[0]) for v in events["values"][:, 0]] == [
        e["values"] for e in trial.events]
    np.testing.assert_array_equal(events["tick"][:, 0], [e["tick"] for e in trial.events])
    subject = mat["subject"][0, 0]
    assert subject["code"][0] == "SIM"
    assert subject["side"][0] == trial.subject.side


def test_mat_exercise_only_keeps_the_exercise_rows(trial, tmp_path):
    (path,) = export_trial(trial, tmp_path, format="mat", exercise_only=True)
    mat = scipy.io.loadmat(path)
    np.testing.assert_array_equal(mat["timeseries"][0, 0]["position"],
                                  trial["position"][trial.exercise])
    assert mat["export"][0, 0]["rows"][0] == "exercise"


# -- CSV / TSV -------------------------------------------------------------------


@pytest.mark.parametrize(("format", "delimiter"), [("csv", ","), ("tsv", "\t")])
def test_table_reads_back_exactly_with_its_units_beside_it(trial, trial_file, tmp_path, format,
                                                           delimiter):
    paths = export_trial(trial_file, tmp_path, format=format)
    assert [p.name for p in paths] == [f"T1.{format}", f"T1_columns.{format}",
                                       f"T1_events.{format}", f"T1_metrics.{format}",
                                       f"T1_trial.{format}"]
    rows = read_rows(paths[0], delimiter)
    names, data = rows[0], rows[1:]
    columns = table_columns(trial.arrays, trial.units, trial.frames, trial.descriptions)
    assert names == [c.name for c in columns]
    described = read_rows(paths[1], delimiter)
    units = {row[0]: row[3] for row in described[1:]}
    assert [units[name] for name in names] == [trial.units[c.channel] for c in columns]
    assert units["position_x_m"] == "m"
    assert units["torque_applied_1_Nm"] == "N*m"
    assert len(data) == trial.n_samples
    table = trial.table()
    for i, name in enumerate(names):
        assert_text_equals([row[i] for row in data], table[name])
    assert data[5][names.index("position_x_m")] == "NaN"
    assert data[6][names.index("force_y_N")] == "Inf"
    assert data[7][names.index("force_x_N")] == "-Inf"


def test_table_with_fewer_digits_stays_within_the_documented_precision(trial, tmp_path):
    (samples, *_) = export_trial(trial, tmp_path, format="tsv", digits=6)
    rows = read_rows(samples, "\t")
    names, data = rows[0], rows[1:]
    table = trial.table()
    for i, name in enumerate(names):
        values = table[name]
        if values.dtype.kind == "f":
            assert_text_equals([row[i] for row in data], values, rtol=5e-6)
        else:
            assert_text_equals([row[i] for row in data], values)
    assert len(samples.read_bytes()) < 0.8 * len(
        export_trial(trial, tmp_path / "full", format="tsv")[0].read_bytes())


def test_side_files_hold_events_metrics_columns_and_parameters(trial, tmp_path):
    _, columns_file, events_file, metrics_file, trial_file = export_trial(
        trial, tmp_path, exercise_only=True)
    events = read_rows(events_file, ",")
    assert events[0] == ["time_s", "tick", "kind", "message", "values"]
    assert [(float(r[0]), int(r[1]), r[2], r[3], json.loads(r[4])) for r in events[1:]] == [
        (e["time_s"], e["tick"], e["kind"], e["message"], e["values"]) for e in trial.events]
    metrics = {r[0]: as_float(r[1]) for r in read_rows(metrics_file, ",")[1:]}
    np.testing.assert_equal(metrics, dict(trial.metrics))
    described = read_rows(columns_file, ",")
    assert described[0] == ["column", "channel", "component", "units", "frame", "description"]
    position_x = next(r[:5] for r in described if r[0] == "position_x_m")
    assert position_x == ["position_x_m", "position", "x", "m", "global"]
    info = dict(read_rows(trial_file, ",")[1:])
    assert info["rows"] == "exercise"
    assert int(info["rows_written"]) == trial.exercise.sum()
    assert info["parameter_shape"] == "d"
    assert float(info["parameter_radius_m"]) == 0.1
    assert info["subject_code"] == "SIM"


def test_exercise_only_table_has_the_exercise_rows(trial, tmp_path):
    samples = export_trial(trial, tmp_path, format="csv", exercise_only=True)[0]
    rows = read_rows(samples, ",")
    time_column = rows[0].index("time_s")
    assert_text_equals([r[time_column] for r in rows[1:]], trial.time[trial.exercise])


# -- BIDS ------------------------------------------------------------------------


def test_bids_dataset_has_the_required_files_and_matches_the_trials(registry, tmp_path):
    registry, code = registry
    result = export_patient(registry, code, tmp_path / "bids", format="bids")
    root = result.folder
    assert result.exported == 3
    assert result.failed == ()
    description = json.loads((root / "dataset_description.json").read_text())
    assert description["BIDSVersion"] == "1.9.0"
    assert description["Name"]
    participants = read_rows(root / "participants.tsv", "\t")
    assert participants[0] == ["participant_id", "body_mass_kg", "upper_arm_m", "forearm_m",
                               "side"]
    assert [r[0] for r in participants[1:]] == [f"sub-{code}"]
    assert sorted(p.name for p in root.glob("sub-*")) == [f"sub-{code}"]
    assert set(json.loads((root / "participants.json").read_text())) == set(participants[0])
    assert (root / "README.md").is_file()

    motion_files = sorted(root.glob("sub-*/ses-*/motion/*_motion.tsv"))
    assert len(motion_files) == 3
    for motion in motion_files:
        match = BIDS_RUN.fullmatch(motion.name)
        assert match, motion.name
        assert motion.parent == root / f"sub-{match['sub']}" / f"ses-{match['ses']}" / "motion"
        trial = load_trial(registry.trial_path(
            next(t for t in registry.trials_for_patient(code)
                 if (t.session_number, t.number) == (int(match["ses"]), int(match["run"])))))
        prefix = motion.name.removesuffix("_motion.tsv")
        sidecar = json.loads((motion.parent / f"{prefix}_motion.json").read_text())
        for key in ("TaskName", "SamplingFrequency", "TrackingSystemName", "Manufacturer",
                    "MotionChannelCount", "RecordingDuration"):
            assert key in sidecar
        assert sidecar["SamplingFrequency"] == 500.0
        assert sidecar["Manufacturer"] == "Quanser"
        assert sidecar["TaskName"] == match["task"] == "d"
        assert sidecar["RecordingDuration"] == pytest.approx(trial.n_samples * 0.002)
        channels = read_rows(motion.parent / f"{prefix}_channels.tsv", "\t")
        assert channels[0][:5] == MOTION_REQUIRED_COLUMNS
        assert all(r[2] in CHANNEL_TYPES and r[1] in COMPONENTS for r in channels[1:])
        assert all(float(r[5]) == 500.0 for r in channels[1:])
        samples = read_rows(motion, "\t")  # no header: the first line is a sample
        assert len(samples) == trial.n_samples
        assert {len(r) for r in samples} == {sidecar["MotionChannelCount"]}
        assert len(channels) - 1 == sidecar["MotionChannelCount"]
        table = trial.table()
        for i, row in enumerate(channels[1:]):
            assert_text_equals([s[i] for s in samples], table[row[0]])
        types = {r[0]: r[2] for r in channels[1:]}
        assert types["position_x_m"] == "POS"
        assert types["subject_angle_isb_elbow_rad"] == "JNTANG"
        assert sum(sidecar[f"{t}ChannelCount"] for t in CHANNEL_TYPES) == len(channels) - 1
        events = read_rows(motion.parent / f"{prefix}_events.tsv", "\t")
        assert events[0][:3] == ["onset", "duration", "trial_type"]
        in_time = sorted(trial.events, key=lambda e: e["time_s"])
        assert [r[2] for r in events[1:]] == [e["kind"] for e in in_time]
        assert [float(r[0]) for r in events[1:]] == [e["time_s"] for e in in_time]


def test_bids_from_a_folder_numbers_runs_and_adds_to_an_existing_dataset(tmp_path):
    folder = tmp_path / "source"
    write(folder / "first.h5", seed=1, code="S-01")
    write(folder / "second.h5", seed=2, code="S-01")
    result = export_folder(folder, tmp_path / "bids", format="bids")
    names = sorted(p.name for p in result.folder.rglob("*_motion.tsv"))
    assert names == ["sub-S01_ses-1_task-d_tracksys-simulator_run-1_motion.tsv",
                     "sub-S01_ses-1_task-d_tracksys-simulator_run-2_motion.tsv"]
    description = (result.folder / "dataset_description.json").read_bytes()

    # BIDS TSV has no quoting: a tab inside a message must not add a column.
    for table in result.folder.rglob("*.tsv"):
        lines = table.read_text(encoding="utf-8").splitlines()
        assert len({line.count("\t") for line in lines}) == 1, table.name
        assert '"' not in lines[0]
    events = next(result.folder.rglob("*run-1_events.tsv")).read_text(encoding="utf-8")
    assert 'mark\t500\ttherapist\'s mark, with "quotes" and a tab\t{"note": "a, b"}' in events

    other = tmp_path / "other"
    write(other / "third.h5", seed=3, code="S02")
    export_folder(other, tmp_path / "bids", format="bids")
    participants = read_rows(result.folder / "participants.tsv", "\t")
    assert [r[0] for r in participants[1:]] == ["sub-S01", "sub-S02"]
    assert (result.folder / "dataset_description.json").read_bytes() == description


# -- names -----------------------------------------------------------------------


def plain_bytes(path: Path) -> bytes:
    """A file's bytes, with the compressed elements of a .mat file inflated."""
    raw = path.read_bytes()
    if path.suffix != ".mat":
        return raw
    parts, offset = [raw[:128]], 128
    while offset + 8 <= len(raw):
        kind, size = struct.unpack("<II", raw[offset:offset + 8])
        body = raw[offset + 8:offset + 8 + size]
        parts.append(zlib.decompress(body) if kind == 15 else body)
        offset += 8 + size + (-size % 8 if kind != 15 else 0)
    return b"".join(parts)


def files_naming(root: Path, *names: str) -> set[str]:
    """Every file under root whose name or content holds one of the names (any case,
    UTF-8 or UTF-16)."""
    found = set()
    for path in root.rglob("*"):
        relative = path.relative_to(root).as_posix()
        if any(n.lower() in relative.lower() for n in names):
            found.add(relative)
        if path.is_file():
            content = plain_bytes(path).lower()
            for n in names:
                if n.lower().encode() in content or n.lower().encode("utf-16-le") in content:
                    found.add(relative)
    return found


@pytest.mark.parametrize("format", ["csv", "tsv", "mat", "bids"])
def test_names_never_appear_unless_asked(registry, tmp_path, format):
    registry, code = registry
    result = export_patient(registry, code, tmp_path / "out", format=format)
    assert result.exported == 3
    assert len(list(result.folder.rglob("*"))) >= 4
    assert files_naming(result.folder, FIRST, LAST) == set()


def test_the_scan_finds_text_inside_a_compressed_mat_file(tmp_path):
    # The guard for the two tests below: a scan that could not see into .mat files
    # would pass them whatever the export wrote.
    (path,) = export_trial(write(tmp_path / "t.h5", code="Quaxworth9"), tmp_path / "out",
                           format="mat")
    assert LAST.encode() not in path.read_bytes()  # compressed, so only inflating finds it
    assert files_naming(tmp_path / "out", LAST) == {"t.mat"}


@pytest.mark.parametrize(("format", "holder"), [("csv", "names.csv"), ("tsv", "names.tsv"),
                                                ("mat", "names.csv"),
                                                ("bids", "participants.tsv")])
def test_names_asked_for_go_only_in_the_participants_file(registry, tmp_path, format, holder):
    registry, code = registry
    result = export_patient(registry, code, tmp_path / "out", format=format,
                            include_names=True)
    assert files_naming(result.folder, FIRST, LAST) == {holder}
    rows = read_rows(result.folder / holder, "," if holder.endswith(".csv") else "\t")
    header, row = rows[0], rows[1]
    assert row[header.index("first_name")] == FIRST
    assert row[header.index("last_name")] == LAST



def test_names_asked_for_through_a_researchers_login_are_refused(registry, tmp_path):
    """The research role reads every name as '': an export with --include-names through it
    wrote name columns left empty, as if the patients had none, without a word."""
    from app.exports.files import ExportError

    registry, code = registry
    registry.research = True  # as a research login's registry is
    with pytest.raises(ExportError, match="this login is a researcher's: it never reads "
                                          "names") as caught:
        export_patient(registry, code, tmp_path / "out", include_names=True)
    assert "\n" not in str(caught.value)
    assert not (tmp_path / "out").exists()


# -- batches, overwriting, failures ---------------------------------------------------


def test_patient_export_reports_progress_and_indexes_the_trials(registry, tmp_path):
    registry, code = registry
    fractions = []
    result = export_patient(registry, code, tmp_path / "out", progress=fractions.append)
    assert fractions == [0.0, 1 / 3, 2 / 3, 1.0]
    index = read_rows(result.folder / "trials.csv", ",")
    header = index[0]
    assert header[:4] == ["participant", "session", "trial", "export_file"]
    assert [(r[1], r[2]) for r in index[1:]] == [("1", "1"), ("1", "2"), ("2", "1")]
    for row in index[1:]:
        assert (result.folder / row[3]).is_file()
        assert row[3].startswith(f"{code}/{code}_S00")
    assert "metric_rmse_x_m" in header


def test_existing_outputs_are_refused_before_anything_is_written(trial, tmp_path):
    blocker = tmp_path / "T1_trial.csv"
    blocker.write_text("keep me")
    with pytest.raises(OutputExistsError, match=r"T1_trial\.csv.*--overwrite"):
        export_trial(trial, tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["T1_trial.csv"]
    assert blocker.read_text() == "keep me"
    export_trial(trial, tmp_path, overwrite=True)
    assert blocker.read_text().startswith("key,value")


@pytest.mark.parametrize("format", ["csv", "mat", "bids"])
def test_a_second_batch_export_is_refused_unless_overwrite(registry, tmp_path, format):
    registry, code = registry
    first = export_patient(registry, code, tmp_path / "out", format=format)
    before = {p: p.read_bytes() for p in first.files}
    with pytest.raises(OutputExistsError, match="Nothing was written"):
        export_patient(registry, code, tmp_path / "out", format=format)
    assert {p: p.read_bytes() for p in first.files} == before
    again = export_patient(registry, code, tmp_path / "out", format=format, overwrite=True)
    assert again.exported == 3
    assert not list((tmp_path / "out").rglob("*.part"))


@pytest.mark.parametrize(("format", "index"), [("csv", "trials.csv"), ("tsv", "trials.tsv"),
                                               ("mat", "trials.csv")])
def test_patient_after_patient_into_one_folder_adds_to_its_index(tmp_path, format, index):
    """Exporting a second patient into the folder of the first (the data folder's
    exports/<format> is every export's default) was refused for the index alone, and with
    overwrite the index listed only the second patient while the first's files stayed
    beside it. As BIDS adds to its dataset, the index and names.csv now keep the other
    trials' rows."""
    registry = Registry(DataDir(tmp_path / "data"))
    codes = []
    for seed, (first, last) in enumerate((("Ann", "One"), ("Bo", "Two"))):
        code = registry.create_patient(first, last, body_mass_kg=70.0).code
        begun = registry.begin_trial(code, D, backend="simulator")
        write(begun.path, seed=seed, code=code)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.001})
        codes.append(code)
    out = tmp_path / "out"
    delimiter = "\t" if format == "tsv" else ","
    names = "names.tsv" if format == "tsv" else "names.csv"
    export_patient(registry, codes[0], out, format=format, include_names=True)
    export_patient(registry, codes[1], out, format=format, include_names=True)
    rows = read_rows(out / index, delimiter)
    assert [r[0] for r in rows[1:]] == codes
    assert all((out / r[3]).is_file() for r in rows[1:])
    assert [r[:2] for r in read_rows(out / names, delimiter)[1:]] == sorted(
        [[codes[0], "Ann"], [codes[1], "Bo"]])
    # the second again, replacing its files: the first's row stays
    export_patient(registry, codes[1], out, format=format, overwrite=True)
    assert [r[0] for r in read_rows(out / index, delimiter)[1:]] == codes
    # a row whose files were removed meanwhile is dropped
    for path in (out / codes[0]).iterdir():
        path.unlink()
    export_patient(registry, codes[1], out, format=format, overwrite=True)
    assert [r[0] for r in read_rows(out / index, delimiter)[1:]] == [codes[1]]


def test_two_exports_into_one_folder_at_once_both_stay_in_its_index(tmp_path, monkeypatch):
    """Two exports at once (two consoles, the window and `rehab export`): each read the
    index and replaced it, so the one that read first and wrote last dropped the other's
    rows while its files stayed in the folder, unlisted."""
    import threading

    from app.exports import index as index_module

    registry = Registry(DataDir(tmp_path / "data"))
    codes = []
    for seed, first in enumerate(("Ann", "Bo")):
        code = registry.create_patient(first, "Example", body_mass_kg=70.0).code
        begun = registry.begin_trial(code, D, backend="simulator")
        write(begun.path, seed=seed, code=code)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.001})
        codes.append(code)
    out = tmp_path / "out"
    read_first, other_done = threading.Event(), threading.Event()
    earlier = index_module._earlier
    reads = []

    def slow_reader(path, *args):
        rows = earlier(path, *args)
        if path.name == "trials.csv":
            reads.append(threading.current_thread())
            if len(reads) == 2:  # the first export's read as it writes its index
                read_first.set()
                other_done.wait(3.0)  # the other export's whole write, unless it waits
        return rows

    monkeypatch.setattr(index_module, "_earlier", slow_reader)
    first = threading.Thread(target=export_patient, args=(registry, codes[0], out))
    first.start()
    assert read_first.wait(60.0)
    second = threading.Thread(target=lambda: (export_patient(registry, codes[1], out),
                                              other_done.set()))
    second.start()
    first.join()
    second.join()
    assert sorted(r[0] for r in read_rows(out / "trials.csv", ",")[1:]) == sorted(codes)


def test_an_index_the_console_did_not_write_is_not_added_to(registry, tmp_path):
    registry, code = registry
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "trials.csv").write_text("x,y\n1,2\n")
    with pytest.raises(OutputExistsError, match="not an index of the console's exports"):
        export_patient(registry, code, tmp_path / "out")
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["trials.csv"]
    export_patient(registry, code, tmp_path / "out", overwrite=True)
    assert read_rows(tmp_path / "out" / "trials.csv", ",")[0][0] == "participant"


def test_unwritable_destination_names_the_folder(trial, tmp_path, monkeypatch):
    blocker = tmp_path / "file"
    blocker.write_text("in the way")
    with pytest.raises(ExportError, match=rf"{blocker / 'exports'}"):
        export_trial(trial, blocker / "exports")

    def refuse(**kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(export_files_module.tempfile, "mkstemp", refuse)
    with pytest.raises(ExportError, match=rf"cannot write in the export folder "
                                          rf"{tmp_path / 'ro'}: Permission denied"):
        export_trial(trial, tmp_path / "ro")


def test_a_failed_write_leaves_no_partial_file(trial, tmp_path, monkeypatch):
    def full(temporary, path, overwrite):
        raise OSError(errno.ENOSPC, "No space left on device")

    import device.safewrite

    monkeypatch.setattr(device.safewrite, "_into_place", full)
    with pytest.raises(ExportError, match=r"writing .*T1\.mat failed: No space left"):
        export_trial(trial, tmp_path, format="mat")
    assert list(tmp_path.iterdir()) == []


def test_folder_export_keeps_going_past_a_damaged_file(tmp_path):
    source = tmp_path / "source"
    write(source / "p1" / "good.h5", seed=1)
    (source / "p1" / "damaged.h5").write_bytes(b"\x89HDF\r\n\x1a\n" + b"\x00" * 64)
    write(source / "p2" / "also_good.h5", seed=2)
    fractions = []
    result = export_folder(source, tmp_path / "out", format="tsv", progress=fractions.append)
    assert result.exported == 2
    assert [f.path.name for f in result.failed] == ["damaged.h5"]
    assert "damaged" in result.failed[0].reason or "HDF5" in result.failed[0].reason
    assert (result.folder / "p1" / "good.tsv").is_file()
    assert (result.folder / "p2" / "also_good.tsv").is_file()
    assert len(read_rows(result.folder / "trials.tsv", "\t")) == 3
    assert fractions[-1] == 1.0
    assert len(fractions) == 4


def test_bids_export_keeps_going_past_a_missing_file(trial_file, tmp_path):
    missing = tmp_path / "gone.h5"
    result = export_trials([trial_file, missing], tmp_path / "bids", format="bids")
    assert result.exported == 1
    assert [(f.path, "does not exist" in f.reason) for f in result.failed] == [(missing, True)]
    assert len(list(result.folder.rglob("*_motion.tsv"))) == 1


def test_two_sources_with_one_output_name_are_refused(trial_file, tmp_path):
    sources = [TrialSource(trial_file, "same"), TrialSource(trial_file.with_name("x.h5"), "same")]
    with pytest.raises(ExportError, match="would both be exported"):
        export_trials(sources, tmp_path)
    assert list(tmp_path.iterdir()) == []


def test_bad_options_are_refused(trial, registry, tmp_path):
    registry, code = registry
    with pytest.raises(ExportError, match="export format 'xlsx'"):
        export_trial(trial, tmp_path, format="xlsx")
    with pytest.raises(ExportError, match="digits = 0"):
        export_trial(trial, tmp_path, digits=0)
    with pytest.raises(ExportError, match="exercise_only and digits apply to csv"):
        export_patients(registry, [code], tmp_path, format="bids", exercise_only=True)
    with pytest.raises(AppError):
        export_folder(tmp_path / "missing", tmp_path / "out")


def test_mat_holds_the_groups_beside_the_samples(tmp_path):
    """The learned feedforward (/assistance) and a table of columns (/emg/channels-like)
    reach the .mat and the loader: a researcher gets everything the file holds."""
    import h5py

    from app.trials.headless import save

    params = D.replace(repetitions=2, assist="as-needed")
    path = tmp_path / "asneeded.h5"
    save(simulate(params, patient="passive"), path)
    from device.recording.trialfile import open_for_update

    # a group with text columns and a subgroup, as /emg, added as the console adds (sealed)
    with open_for_update(path, "/emg") as f:
        group = f.create_group("emg")
        group.attrs["rate_hz"] = 1925.926
        table = np.array([("EMG1", "biceps_brachii")],
                         dtype=[("name", h5py.string_dtype()), ("muscle", h5py.string_dtype())])
        group.create_dataset("channels", data=table)
        group.create_group("mvc").create_group("biceps_brachii").attrs["mvc_V"] = 0.5
    trial = load_trial(path)
    assert set(trial.groups) == {"assistance", "emg"}
    feedforward = trial.groups["assistance"]["feedforward_N"]
    assert feedforward.shape[0] == 2
    (out,) = export_trial(trial, tmp_path, format="mat")
    mat = scipy.io.loadmat(out)
    assistance = mat["assistance"][0, 0]
    np.testing.assert_array_equal(assistance["feedforward_N"], feedforward)
    assert assistance["mode"][0] == "as-needed"
    emg = mat["emg"][0, 0]
    assert emg["rate_hz"][0, 0] == pytest.approx(1925.926)
    assert emg["channels"][0, 0]["muscle"][0, 0][0] == "biceps_brachii"
    assert emg["mvc"][0, 0]["biceps_brachii"][0, 0]["mvc_V"][0, 0] == 0.5
