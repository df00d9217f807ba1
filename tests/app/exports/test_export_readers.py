"""The text exports as researchers' own tools read them, with no options: pandas and numpy
take every samples file with numeric columns of the right type and the trial's exact
values (a units line under the header made pandas read every column as text and numpy's
names=True read it as a sample), the side files and the batch index too; and load_study
given an export folder says in one line what to give it (it returned 0 trials)."""

import numpy as np
import pandas as pd
import pytest

from app.errors import AppError
from app.exports.loader import load_study, load_trial
from app.exports.run import export_folder, export_trial
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT


@pytest.fixture(scope="module")
def trial_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("trials") / "T1.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python"), path)
    return path


@pytest.mark.parametrize(("format", "separator"), [("csv", ","), ("tsv", "\t")])
def test_pandas_and_numpy_read_the_samples_as_numbers_without_options(trial_file, tmp_path,
                                                                      format, separator):
    samples, columns, events, metrics, trial_info = export_trial(trial_file, tmp_path,
                                                                 format=format)
    table = load_trial(trial_file).table()
    frame = pd.read_csv(samples, sep=separator)
    assert list(frame.columns) == list(table)
    assert len(frame) == len(next(iter(table.values())))
    for name, values in table.items():
        kind = frame[name].dtype.kind
        assert kind in "fi", f"{name} read as {frame[name].dtype}"
        if np.issubdtype(np.asarray(values).dtype, np.integer):
            assert kind == "i", f"{name}: an integer channel read as {frame[name].dtype}"
        np.testing.assert_array_equal(frame[name].to_numpy(dtype=float),
                                      np.asarray(values, dtype=float), err_msg=name)
    array = np.genfromtxt(samples, delimiter=separator, names=True)
    assert array.shape == (len(frame),)
    assert array["tick"][0] == table["tick"][0]  # the first sample, not a units line
    np.testing.assert_array_equal(array["position_x_m"], table["position_x_m"])
    described = pd.read_csv(columns, sep=separator)
    assert described.set_index("column").loc["position_x_m", "units"] == "m"
    assert pd.read_csv(events, sep=separator)["time_s"].dtype.kind == "f"
    assert pd.read_csv(metrics, sep=separator)["value"].dtype.kind == "f"
    assert set(pd.read_csv(trial_info, sep=separator)["key"]) >= {"status", "rows"}


def test_the_batch_index_reads_as_one_row_per_trial(trial_file, tmp_path):
    result = export_folder(trial_file.parent, tmp_path / "out")
    index = pd.read_csv(result.folder / "trials.csv")
    assert len(index) == 1
    assert index["export_file"].iloc[0].endswith(".csv")
    assert index["metric_rmse_x_m"].dtype.kind == "f"


def test_load_study_on_an_export_folder_says_what_to_give_it(trial_file, tmp_path):
    result = export_folder(trial_file.parent, tmp_path / "out")
    with pytest.raises(AppError, match=r"holds no trial files \(\*\*/\*\.h5\).* an export "
                                       r"of the console: read its trials\.csv") as refused:
        load_study(result.folder)
    assert "\n" not in str(refused.value)
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(AppError, match="holds no trial files"):
        load_study(empty)
    assert len(load_study(trial_file.parent).infos) == 1
