"""TrialView: live batches into growing buffers, figures equal to app.trials.analysis,
replay cursor."""

from __future__ import annotations

import numpy as np
import pytest

from app.trials.analysis import analyse
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.metrics import directional_performance
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PHASE_EXERCISE
from ui.views.trialview import VIEW_CHANNELS, TrialView

PARAMETERS = THESIS_SUBJECT.replace(repetitions=1)


@pytest.fixture(scope="module")
def trial():
    return simulate(PARAMETERS, seed=3)


@pytest.fixture(scope="module")
def records(trial):
    return trial.records


def batches(records, size):
    return [records[i:i + size] for i in range(0, len(records), size)]


def test_append_doubles_capacity_and_keeps_the_concatenated_batches(records):
    view = TrialView(PARAMETERS, initial_capacity=64)
    capacities = []
    for batch in batches(records, 17):  # ~30 ms of records per 60 Hz frame
        view.append(batch)
        capacities.append(view.capacity)
    # Grown by doubling only: 64 -> 128 -> ... -> 4096, one reallocation per step,
    # not one per frame.
    steps = sorted(set(capacities))
    assert steps == [64 * 2**k for k in range(len(steps))]
    assert view.reallocations == len(steps) - 1 < len(capacities) / 10
    assert view.n == len(records) <= view.capacity
    for name in VIEW_CHANNELS:
        expected = records[name].reshape(len(records), -1).T
        np.testing.assert_array_equal(view.column(name), expected, err_msg=name)


def test_no_reallocation_while_capacity_lasts(records):
    view = TrialView(PARAMETERS, initial_capacity=8192)
    column = view.column("force").base
    for batch in batches(records, 25):
        view.append(batch)
    assert view.reallocations == 0
    assert view.column("force").base is column


def test_running_figures_equal_the_analysis(records):
    view = TrialView(PARAMETERS, initial_capacity=256)
    for batch in batches(records, 33):
        view.append(batch)
    channels = {name: records[name] for name in records.dtype.names}
    metrics = analyse(channels, PARAMETERS).metrics
    rx, ry = view.rmse_xy_m
    assert rx == pytest.approx(metrics.rmse_x_m, rel=1e-9)
    assert ry == pytest.approx(metrics.rmse_y_m, rel=1e-9)
    assert view.directional_percent == pytest.approx(metrics.directional_performance_pct,
                                                     rel=1e-9)
    for name, keys in (("force", ("force_range_x_N", "force_range_y_N")),
                       ("subject_angle_isb", ("shoulder_rom_rad", "elbow_rom_rad")),
                       ("subject_torque", ("shoulder_torque_range_Nm", "elbow_torque_range_Nm"))):
        low, high = view.range_of(name)
        for j, key in enumerate(keys):
            assert high[j] - low[j] == pytest.approx(getattr(metrics, key), rel=1e-12), key


def test_within_mask_matches_directional_performance(records):
    view = TrialView.from_records(records, PARAMETERS)
    exercise = records["phase"] == PHASE_EXERCISE
    expected = directional_performance(
        records["time"][exercise], records["force"][exercise],
        records["direction_desired"][exercise], PARAMETERS.tolerance_rad).within
    np.testing.assert_array_equal(view.within[view.exercise], expected)
    assert 0 < expected.sum() < expected.size  # both colours occur: the test can fail


def test_memory_is_bounded_by_thinning(records):
    view = TrialView(PARAMETERS, initial_capacity=64, max_samples=300)
    for batch in batches(records, 17):
        view.append(batch)
    assert view.n <= 300
    assert view.capacity <= 300
    assert view.stride > 1
    np.testing.assert_array_equal(view.time, records["time"][::view.stride])
    # The figures still count every sample.
    full = TrialView.from_records(records, PARAMETERS)
    assert view.rmse_xy_m == pytest.approx(full.rmse_xy_m, rel=1e-12)
    assert view.directional_percent == pytest.approx(full.directional_percent, rel=1e-12)


def test_cursor_clamps_and_finds_its_sample(records):
    view = TrialView.from_records(records, PARAMETERS)
    assert view.cursor is None
    assert view.current_index == view.n - 1
    view.cursor = 1.2345
    assert view.time[view.current_index] <= 1.2345 < view.time[view.current_index + 1]
    view.cursor = -5.0
    assert view.cursor == view.time[0]
    assert view.current_index == 0
    view.cursor = 1e9
    assert view.current_index == view.n - 1


def test_from_trial_file(trial, tmp_path):
    path = tmp_path / "trial.h5"
    save(trial, path)
    view = TrialView.from_trial(read_trial(path))
    assert view.finished
    assert view.source == path
    assert view.parameters == PARAMETERS
    assert view.metrics["rmse_x_m"] == pytest.approx(view.rmse_xy_m[0], rel=1e-9)
    np.testing.assert_array_equal(view.column("position"), trial.records["position"].T)
