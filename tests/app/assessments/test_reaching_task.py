"""Visually guided reaching end to end on the simulator: the healthy, weak and passive
virtual patients each run the task's trial (core.assessment.protocol) through the headless
runner, their own movements after their own reaction (device.sim.tasks), and the figures in
the trial file's metrics order them as expected (Coderre et al. 2010's parameters,
core.assessment.reaching)."""

import math

import pytest

from app.assessments.events import CUE_EVENT
from app.assessments.runner import run_task
from app.trials.reader import read_trial
from core.assessment import task_figures
from core.assessment.protocol import cues, protocol
from core.trial import TrialParameters
from device.loop.pipeline import PERIOD_S, PHASE_EXERCISE


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    folder = tmp_path_factory.mktemp("reaching")
    return {kind: run_task("reaching", kind, seed=5, folder=folder)[0]
            for kind in ("healthy", "weak", "passive")}


def test_every_figure_is_in_the_file_as_the_runner_says(runs):
    keys = {spec.key for spec in task_figures("reaching")}
    for run in runs.values():
        assert run.status == "complete"
        assert set(run.figures) == keys
        stored = read_trial(run.path, ()).metrics
        for key in keys:
            assert stored[key] == pytest.approx(run.figures[key], nan_ok=True), key
        assert read_trial(run.path, ()).parameters.assessment == "reaching"


def test_the_figures_order_healthy_weak_passive(runs):
    healthy, weak, passive = (runs[k].figures for k in ("healthy", "weak", "passive"))
    n = 8 * protocol("reaching").repetitions
    # everyone holds still before a target: the posture is measured, not carried over
    assert healthy["vgr_posture_speed_m_s"] < 0.01
    assert weak["vgr_posture_speed_m_s"] < 0.01
    for key in ("vgr_reaction_time_s", "vgr_movement_time_s", "vgr_speed_maxima_count"):
        assert healthy[key] < weak[key], key
    assert healthy["vgr_max_speed_m_s"] > weak["vgr_max_speed_m_s"] > passive["vgr_max_speed_m_s"]
    assert healthy["vgr_sparc"] > weak["vgr_sparc"]  # smoother: closer to 0
    assert healthy["vgr_ldlj"] > weak["vgr_ldlj"]
    assert healthy["vgr_no_reaction_count"] == 0
    assert weak["vgr_no_reaction_count"] == 0
    # a relaxed arm never reaches: every reach counted, nothing else defined
    assert passive["vgr_no_reaction_count"] == n
    assert passive["vgr_no_movement_end_count"] == n
    assert math.isnan(passive["vgr_reaction_time_s"])
    # a healthy reaction is the model's 0.30 s plus the time to reach the onset threshold
    assert 0.3 < healthy["vgr_reaction_time_s"] < 0.45


def test_the_cues_are_timed_events_on_the_exercises_clock(runs):
    run = runs["healthy"]
    data = read_trial(run.path, ("phase",))
    first = int((data.channels["phase"] == PHASE_EXERCISE).argmax())
    shown = [e for e in data.events if e["kind"] == CUE_EVENT]
    expected = cues(protocol("reaching").parameters(TrialParameters()))
    assert len(shown) == len(expected)
    for event, cue in zip(shown, expected, strict=True):
        assert event["tick"] == first + round(cue.time_s / PERIOD_S)
        assert event["values"]["point_m"] == pytest.approx(list(cue.point_m))
        assert event["message"] == ("target shown" if cue.kind == "target" else "centre shown")


def test_a_file_that_exists_is_never_written_over(runs, tmp_path):
    run_path = runs["passive"].path
    with pytest.raises(Exception, match="already exists"):
        run_task("reaching", "passive", seed=5, folder=run_path.parent)


def test_the_live_loop_writes_the_same_cues_on_the_same_ticks(runs):
    """device.loop.pipeline's task events (what the live loop sends the recorder) are the
    headless file's, from the exercise's first tick."""
    from device.loop.pipeline import TrialPlan

    run = runs["weak"]
    data = read_trial(run.path, ("phase",))
    first = int((data.channels["phase"] == PHASE_EXERCISE).argmax())
    live = TrialPlan.build(run.parameters).task_events()
    stored = [e for e in data.events if e["kind"] == CUE_EVENT]
    assert [(first + k, kind, message, values) for k, kind, message, values in live] == [
        (e["tick"], e["kind"], e["message"], e["values"]) for e in stored]


def test_a_weak_arm_that_lost_selectivity_reaches_in_more_pieces_than_a_healthy_one(runs):
    """With the loss of selective joint control (device.sim.patients, selectivity) the weak
    arm's reaches keep their submovements (device.sim.submovements): more speed maxima and
    less smooth than the healthy reaches, where without the pieces it had fewer maxima
    (docs/assessments.md, Submovements)."""
    healthy = runs["healthy"].figures
    lost = run_task("reaching", "weak", seed=5, in_memory=True,
                    patient_options={"selectivity_loss": 0.5})[0].figures
    assert lost["vgr_speed_maxima_count"] > healthy["vgr_speed_maxima_count"] + 0.5
    assert lost["vgr_sparc"] < healthy["vgr_sparc"]
    assert lost["vgr_initial_direction_error_rad"] > healthy["vgr_initial_direction_error_rad"]
