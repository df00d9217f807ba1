"""Strength figures the robot capped: with the robot's hold at its force limit, a push's
force is the robot's limit, not the person's (core.assessment FigureSpec.bounded_by). The
shipped simulated norms were fitted on 482 controls every one of whom reached the limit
in every direction: a spike at the limit the Box-Cox stretched (λ at its bound) into a
Z-score of −48,757,957 for the passive patient's peak force. Now a figure capped in more
than 5 % of the controls (the peaks) is not normed, the fit says why in the file's notes,
and a report asking for it gets that reason in its one line."""

from __future__ import annotations

import json

import numpy as np
import pytest

from app.norms import Covariates, NormsError, load_norms, write_norms
from app.norms.fitting import MAX_BOUNDED_FRACTION, Controls, fit_norms, task_figures_for_score
from core.assessment import FIGURES

STRENGTH = task_figures_for_score("strength", FIGURES)
PERSON = Covariates(60.0, "female", "right", "right", "simulator-realistic")


def _controls(capped: int, n: int = 100) -> Controls:
    rng = np.random.default_rng(1)
    people = tuple(Covariates(float(rng.uniform(20, 80)), str(rng.choice(["female", "male"])),
                              "right", "right", "simulator-realistic") for _ in range(n))
    figures = {key: rng.normal(30.0, 5.0, n) for key in STRENGTH}
    at_limit = np.zeros(n)
    at_limit[:capped] = rng.integers(1, 9, capped)
    figures["strength_at_limit_count"] = at_limit
    return Controls(tuple(f"C{i:03d}" for i in range(n)), people, figures)


def test_the_strength_peaks_name_the_count_that_caps_them():
    assert STRENGTH == ["strength_peak_force_n", "strength_mean_force_n"]
    peaks = [k for k in FIGURES if k.startswith("strength_peak_force_n")]
    assert len(peaks) == 9
    assert all(FIGURES[k].bounded_by == "strength_at_limit_count" for k in peaks)
    # the mean over a push says how soon the line was reached: not capped the same way
    assert FIGURES["strength_mean_force_n"].bounded_by == ""
    assert FIGURES["vgr_max_speed_m_s"].bounded_by == ""


def test_a_figure_capped_in_many_controls_is_not_normed_and_the_file_says_why(tmp_path):
    report = fit_norms(_controls(capped=30), "test controls")
    assert "strength_peak_force_n" not in report.document["figures"]
    assert report.left_out["strength_peak_force_n"].startswith(
        "30 of 100 controls reached the robot's limit")
    assert "strength_mean_force_n" in report.document["figures"]
    assert report.document["tasks"]["strength"]["figures"] == ["strength_mean_force_n"]
    path = write_norms(tmp_path / "n.json", report.document)
    model = load_norms(path)
    assert "reached the robot's limit" in model.left_out("strength_peak_force_n")
    with pytest.raises(NormsError, match="30 of 100 controls reached the robot's limit"):
        model.z("strength_peak_force_n", 5.0, PERSON)


def test_a_task_left_out_says_why_its_figure_was(tmp_path):
    """Every figure of a task capped: the task's note names the figure's own reason."""
    controls = _controls(capped=30)
    figures = dict(controls.figures)
    del figures["strength_mean_force_n"]
    report = fit_norms(Controls(controls.subjects, controls.people, figures), "test controls")
    assert "strength" not in report.document["tasks"]
    model = load_norms(write_norms(tmp_path / "n.json", report.document))
    with pytest.raises(NormsError, match="hold no task score for 'strength': lacks "
                       r"strength_peak_force_n, strength_mean_force_n \(strength_peak_force_n: "
                       "30 of 100 controls reached the robot's limit"):
        model.task_score("strength", {k: 5.0 for k in STRENGTH}, PERSON)


def test_a_few_capped_controls_still_norm_the_figure():
    few = int(MAX_BOUNDED_FRACTION * 100)  # 5 of 100: not more than 5 %
    report = fit_norms(_controls(capped=few), "test controls")
    assert set(STRENGTH) <= set(report.document["figures"])
    assert "strength" in report.document["tasks"]


def test_the_notes_stay_within_the_files_limit():
    from app.norms.fitting import left_out_notes

    text = left_out_notes({f"figure_{i}": "x" * 90 for i in range(200)})
    assert len(text) <= 5000
    assert text.startswith("Left out by the fit:\nfigure_0: ")
    assert text.endswith("to see them all)")
    json.dumps(text)
