"""A task score fitted when one of its figures has no spread among the controls (the
virtual healthy population's initial speed ratio is 1 in every reach): the score combines
the task's other figures and the fit says which it went without; with fewer than half of
its figures normed the task is left out. Before, one such figure left the whole task out:
the shipped simulated norms had no reaching and no position-sense task score."""

from __future__ import annotations

import numpy as np

from app.norms import Covariates
from app.norms.fitting import Controls, fit_norms, task_figures_for_score
from core.assessment import FIGURES

REACHING = task_figures_for_score("reaching", FIGURES)


def _controls(constant: set[str], n: int = 80) -> Controls:
    rng = np.random.default_rng(0)
    people = tuple(Covariates(float(rng.uniform(20, 80)), str(rng.choice(["female", "male"])),
                              "right", "right", "simulator-realistic") for _ in range(n))
    figures = {key: (np.full(n, 1.0) if key in constant
                     else np.exp(rng.normal(-1.0, 0.2, n))) for key in REACHING}
    return Controls(tuple(f"C{i:03d}" for i in range(n)), people, figures)


def test_a_figure_without_spread_is_left_out_of_its_task_score_not_the_task():
    report = fit_norms(_controls({"vgr_initial_speed_ratio"}), "test controls")
    task = report.document["tasks"]["reaching"]
    assert "vgr_initial_speed_ratio" not in task["figures"]
    assert set(task["figures"]) == set(REACHING) - {"vgr_initial_speed_ratio"}
    assert report.left_out["task:reaching"] == "scored without vgr_initial_speed_ratio"
    assert "no spread" in report.left_out["vgr_initial_speed_ratio"]


def test_a_task_with_fewer_than_half_its_figures_normed_is_left_out():
    constant = set(REACHING[: len(REACHING) // 2 + 1])
    report = fit_norms(_controls(constant), "test controls")
    assert "reaching" not in report.document["tasks"]
    assert report.left_out["task:reaching"].startswith("lacks ")
