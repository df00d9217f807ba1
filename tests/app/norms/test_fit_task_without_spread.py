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


def test_a_figure_nearly_every_control_has_at_one_value_is_not_normed():
    """The simulated controls' count of reaches with no reaction: 0 in 481 of 482. Normed,
    its held-out Z-scores had an SD of 0.09 (not 1): left out, saying why."""
    from app.norms.fitting import MIN_CONTROLS

    controls = _controls(set())
    rare = np.zeros(len(controls.people))
    rare[: MIN_CONTROLS - 1] = 1.0
    figures = dict(controls.figures, vgr_no_reaction_count=rare)
    report = fit_norms(Controls(controls.subjects, controls.people, figures), "test controls")
    assert "vgr_no_reaction_count" not in report.document["figures"]
    assert report.left_out["vgr_no_reaction_count"] == (
        f"only {MIN_CONTROLS - 1} controls differ from the commonest value, fewer than "
        f"{MIN_CONTROLS}: too little spread to norm")
    rare[MIN_CONTROLS - 1] = 2.0  # 20 off it: normed
    figures = dict(controls.figures, vgr_no_reaction_count=rare)
    report = fit_norms(Controls(controls.subjects, controls.people, figures), "test controls")
    assert "vgr_no_reaction_count" in report.document["figures"]


def test_as_few_controls_as_the_minimum_are_fitted_when_their_values_differ():
    """docs/norms.md: a figure is fitted when at least MIN_CONTROLS controls have it with a
    spread. With exactly MIN_CONTROLS people, each their own value, one of them was taken
    as "the commonest value" and only MIN_CONTROLS − 1 "differ from it": every figure was
    left out and the fit refused a study of 20 controls (24 with 4 left-handers)."""
    from app.norms.fitting import MIN_CONTROLS

    report = fit_norms(_controls(set(), n=MIN_CONTROLS), "test controls")
    assert set(report.document["figures"]) == set(REACHING)
    assert not any(key in report.left_out for key in REACHING)
