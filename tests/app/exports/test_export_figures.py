"""An export writes the figures the registry stands by (app.exports.figures): after `rehab
reanalyse` re-computed a trial's figures, `rehab export` of the patient, of the trial or of
the data folder's trials writes the registry's, says so (`metrics_source`, a note), and
keeps the file's own beside them. Before, every export wrote the file's /metrics as
recorded: the old figures, with no word that newer ones existed."""

from __future__ import annotations

import csv
import math
from dataclasses import replace

import pytest
import scipy.io
from hypothesis import given, strategies as st

from app.exports.figures import RECORDED, REGISTRY, SOURCE_COLUMN, standing_figures
from app.exports.loader import load_trial
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.reanalyse import same_figure
from tests.app.cli.running import run
from tests.old_analysis import analysed_as_before

NEW = "robot_help_work_J"  # the figure the analysis before 2026-12-05 did not make


@pytest.fixture
def reanalysed(data, patient, capsys, monkeypatch):
    """A patient's trial recorded by the analysis before, then re-analysed: (the registry's
    trial, its file's path)."""
    with monkeypatch.context() as patch:
        analysed_as_before(patch)
        code, _, err = run(["run", "--code", patient, "--patient", "weak",
                            "--repetitions", "1", "--seed", "3"], capsys)
    assert code == 0, err
    code, _, err = run(["reanalyse", "--patient", patient, "--by", "R. Searcher"], capsys)
    assert code == 0, err
    registry = Registry(DataDir(data))
    (trial,) = registry.trials_for_patient(patient)
    assert math.isfinite(trial.metrics[NEW])
    return trial, registry.trial_path(trial)


def rows(path, delimiter=","):
    with path.open(encoding="utf-8", newline="") as stream:
        return list(csv.DictReader(stream, delimiter=delimiter))


def metric_rows(path, delimiter=","):
    return {row["metric"]: row for row in rows(path, delimiter)}


def test_a_patient_export_after_reanalyse_writes_the_registrys_figures(reanalysed, patient,
                                                                       tmp_path, capsys):
    trial, path = reanalysed
    out = tmp_path / "csv"
    code, said, err = run(["export", "--patient", patient, "--output", str(out)], capsys)
    assert code == 0, err
    assert "1 trial(s) exported with the registry's figures" in said
    (row,) = rows(out / "trials.csv")
    assert float(row[f"metric_{NEW}"]) == trial.metrics[NEW]
    assert float(row["metric_robot_work_share"]) == trial.metrics["robot_work_share"]
    assert row[SOURCE_COLUMN] == REGISTRY
    stem = path.stem
    figures = metric_rows(out / patient / f"{stem}_metrics.csv")
    assert float(figures[NEW]["value"]) == trial.metrics[NEW]
    assert figures[NEW]["recorded"] == "NaN"  # the file's /metrics, as recorded
    assert figures["rmse_x_m"]["value"] == figures["rmse_x_m"]["recorded"]
    info = {r["key"]: r["value"] for r in rows(out / patient / f"{stem}_trial.csv")}
    assert info[SOURCE_COLUMN] == REGISTRY
    assert NEW not in load_trial(path).metrics  # the file is as it was recorded


def test_a_trial_export_and_a_folder_export_write_them_too(reanalysed, data, tmp_path,
                                                           capsys):
    trial, path = reanalysed
    code, said, err = run(["export", "--trial", str(trial.id), "--format", "mat",
                           "--output", str(tmp_path / "mat")], capsys)
    assert code == 0, err
    assert "exported with the registry's figures" in said
    mat = scipy.io.loadmat(tmp_path / "mat" / f"{path.stem}.mat", simplify_cells=True)
    assert mat["metrics"][NEW] == trial.metrics[NEW]
    assert NEW not in mat["metrics_recorded"]
    assert mat["export"][SOURCE_COLUMN] == REGISTRY
    code, said, err = run(["export", "--folder", str(data / "trials"), "--format", "tsv",
                           "--output", str(tmp_path / "tsv")], capsys)
    assert code == 0, err
    (row,) = rows(tmp_path / "tsv" / "trials.tsv", "\t")
    assert float(row[f"metric_{NEW}"]) == trial.metrics[NEW]
    assert row[SOURCE_COLUMN] == REGISTRY


def test_a_trial_never_reanalysed_is_exported_as_recorded_without_a_note(data, patient,
                                                                        tmp_path, capsys):
    code, _, err = run(["run", "--code", patient, "--repetitions", "1", "--seed", "1"], capsys)
    assert code == 0, err
    code, said, err = run(["export", "--patient", patient, "--output", str(tmp_path / "o")],
                          capsys)
    assert code == 0, err
    assert "registry's figures" not in said
    (row,) = rows(tmp_path / "o" / "trials.csv")
    assert row[SOURCE_COLUMN] == RECORDED


# -- the rule itself, over any figures -------------------------------------------------

figure = st.floats(allow_nan=True, allow_infinity=False)
figures = st.dictionaries(st.sampled_from(["a", "b", "c", "d"]), figure, max_size=4)


@pytest.fixture(scope="module")
def a_trial(tmp_path_factory):
    from tests.app.exports.test_export import write

    path = tmp_path_factory.mktemp("trial") / "t.h5"
    write(path, seed=0, code="P1ZTTAQ")
    return load_trial(path)


@given(recorded=figures, registry=st.none() | figures)
def test_the_figures_exported_are_the_registrys_and_the_files_are_kept(a_trial, recorded,
                                                                      registry):
    trial = replace(a_trial, metrics=recorded)
    exported, source = standing_figures(trial, registry)
    assert dict(trial.metrics) == recorded  # the file's own, untouched
    differs = registry is not None and any(
        not same_figure(recorded.get(k, math.nan), v) for k, v in registry.items())
    assert source == (REGISTRY if differs else RECORDED)
    for key, value in (registry or {}).items():  # every figure the registry stands by
        assert same_figure(exported.metrics[key], value)
    for key, value in recorded.items():  # and every one the file has, where it has none
        if registry is None or key not in registry:
            assert exported.metrics[key] is value
