"""Per-joint RMSE and bias as Table 3.4 computes them, and the reference-angle CSV."""

from __future__ import annotations

import numpy as np
import pytest

from core.pose.compare import ReferenceCSVError, joint_errors, read_reference_csv

# Table 3.4: regression (the solver) and goniometer, shoulder and elbow, frames 1–10
SOLVER = np.array([[69.8, 101], [76.4, 92.6], [79.7, 82.9], [74.6, 78.3], [63.4, 83.1],
                   [57.6, 94.1], [60.8, 106], [64.6, 99.3], [70.7, 88.0], [68.8, 80.3]])
GONIOMETER = np.array([[69.3, 101], [75.8, 93.2], [78.9, 83.5], [73.9, 79.0], [62.6, 82.3],
                       [58.1, 93.7], [61.7, 105], [65.3, 98.7], [70.0, 88.1], [69.6, 79.7]])


# Table 3.4's printed error columns (computed in the thesis from unrounded readings)
GONIOMETER_ERROR = np.array([[0.52, -0.56], [0.56, -0.65], [0.76, -0.59], [0.69, -0.74],
                             [0.84, 0.82], [-0.48, 0.37], [-0.95, 0.60], [-0.74, 0.62],
                             [0.72, -0.12], [-0.77, 0.61]])
POSE_ERROR = np.array([[0.77, 1.03], [-0.94, 0.89], [-0.87, 0.88], [-0.95, 0.88],
                       [-0.97, 0.73], [0.80, 0.68], [-0.90, -0.86], [0.77, -0.89],
                       [0.82, -0.77], [-0.87, -0.29]])


def pooled_deg(shoulder, elbow) -> float:
    """The thesis's RMSE column pools both joints' errors."""
    return float(np.degrees(np.sqrt((shoulder.rmse_rad**2 * shoulder.n
                                     + elbow.rmse_rad**2 * elbow.n)
                                    / (shoulder.n + elbow.n))))


def test_table_3_4s_own_figures():
    zero = np.zeros((10, 2))
    assert pooled_deg(*joint_errors(zero, np.radians(GONIOMETER_ERROR))) == pytest.approx(
        0.66, abs=0.005)
    assert pooled_deg(*joint_errors(zero, np.radians(POSE_ERROR))) == pytest.approx(
        0.84, abs=0.01)
    # from the readings as printed (rounded to 0.1° or 1°) the figures come out close
    shoulder, elbow = joint_errors(np.radians(GONIOMETER), np.radians(SOLVER))
    assert np.degrees(shoulder.rmse_rad) == pytest.approx(0.72, abs=0.01)
    assert np.degrees(elbow.rmse_rad) == pytest.approx(0.61, abs=0.01)
    assert pooled_deg(shoulder, elbow) == pytest.approx(0.66, abs=0.01)
    assert shoulder.n == elbow.n == 10


def test_bias_gaps_and_a_turn_of_wrap():
    ref = np.zeros((5, 2))
    other = np.array([[0.1, 2 * np.pi + 0.1], [0.1, 0.1], [np.nan, 0.1], [0.1, 0.1],
                      [0.1, 0.1]])
    shoulder, elbow = joint_errors(ref, other)
    assert shoulder.bias_rad == pytest.approx(0.1)
    assert shoulder.rmse_rad == pytest.approx(0.1)
    assert shoulder.n == 4
    assert elbow.n == 5
    assert elbow.max_abs_rad == pytest.approx(0.1)
    none, _ = joint_errors(np.zeros((2, 2)), np.full((2, 2), np.nan))
    assert none.n == 0
    assert np.isnan(none.rmse_rad)


def test_reference_csv_by_frame_and_by_time(tmp_path):
    path = tmp_path / "goniometer.csv"
    path.write_text("frame,shoulder_deg,elbow_deg\n3,69.3,101\n40,75.8,93.2\n")
    ref = read_reference_csv(path)
    assert ref.frame.tolist() == [3, 40]
    assert ref.time_s is None
    assert np.allclose(np.degrees(ref.isb_rad), [[69.3, 101], [75.8, 93.2]])
    path.write_text("time_s,elbow_deg,shoulder_deg\n0.5,101,69.3\n")
    ref = read_reference_csv(path)
    assert ref.time_s.tolist() == [0.5]
    assert np.allclose(np.degrees(ref.isb_rad), [[69.3, 101]])


@pytest.mark.parametrize(("text", "match"), [
    ("", "empty"),
    ("when,shoulder_deg,elbow_deg\n1,2,3\n", "must name"),
    ("frame,shoulder_deg,elbow_deg\n", "no rows"),
    ("frame,shoulder_deg,elbow_deg\n1,abc,3\n", "line 2"),
    ("frame,shoulder_deg,elbow_deg\n1,2\n", "line 2"),
    ("frame,shoulder_deg,elbow_deg\n2,2,3\n1,2,3\n", "must increase"),
    ("frame,shoulder_deg,elbow_deg\n1.5,2,3\n", "whole numbers"),
    ("time_s,shoulder_deg,elbow_deg\n1,nan,3\n", "finite"),
])
def test_a_reference_csv_that_cannot_be_used_is_refused(tmp_path, text, match):
    path = tmp_path / "ref.csv"
    path.write_text(text)
    with pytest.raises(ReferenceCSVError, match=match):
        read_reference_csv(path)
    with pytest.raises(ReferenceCSVError, match="cannot be read"):
        read_reference_csv(tmp_path / "missing.csv")
