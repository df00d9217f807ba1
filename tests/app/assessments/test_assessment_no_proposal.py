"""An assessment trial is no exercise: finalizing it proposes nothing for the next trial
(its transparent mode's "the same again" was kept as the pending proposal, which the
next exercise trial was offered, `rehab run --as-proposed` applied and the window showed),
starting it decides no exercise's proposal (it waits for the next exercise), and
`rehab trials` lists it as "assessment: <task>" with no proposal line."""

from __future__ import annotations

from app.trials.finalize import finalize_trial
from core.trial import THESIS_SUBJECT
from tests.app.assessments.registered import register
from tests.app.cli.running import run

EXERCISE = THESIS_SUBJECT.replace(repetitions=1)
REACHING = THESIS_SUBJECT.replace(assist="transparent", shape="targets")


def _patient(registry) -> str:
    return registry.create_patient("Ada", "Example", side="right").code


def test_an_assessment_makes_no_proposal_and_decides_none(registry):
    code = _patient(registry)
    exercise = register(registry, code, {}, task="", parameters=EXERCISE, finish=False)
    done = finalize_trial(registry, exercise.trial_id, "complete")
    assert done.proposal is not None
    waiting = registry.pending_proposal(code)
    assert waiting.trial_id == exercise.trial_id

    assessment = register(registry, code, {"vgr_reaction_time_s": 0.4},
                          parameters=REACHING, finish=False)
    done = finalize_trial(registry, assessment.trial_id, "complete")
    assert done.proposal is None
    assert registry.proposal(assessment.trial_id) is None
    # the exercise's proposal still waits for the next exercise, undecided
    still = registry.pending_proposal(code)
    assert still.trial_id == exercise.trial_id
    assert still.decision == "pending"
    assert still.next_trial_id is None
    after = register(registry, code, {}, task="", parameters=EXERCISE, finish=False)
    assert registry.proposal(exercise.trial_id).next_trial_id == after.trial_id
    assert registry.proposal(exercise.trial_id).decision == "kept"


def test_the_trials_list_shows_an_assessment_as_its_task_without_a_proposal(registry,
                                                                          capsys):
    code = _patient(registry)
    exercise = register(registry, code, {"rmse_x_m": 0.002, "rmse_y_m": 0.003}, task="",
                        parameters=EXERCISE)
    registry.record_proposal(exercise.trial_id, {
        "assistance_level": 1.0, "duration_s": 4.0, "tolerance_rad": 0.349,
        "change": "none", "reason": "exercise reason"})
    assessment = register(registry, code, {"rmse_x_m": 0.03, "rmse_y_m": 0.03},
                          parameters=REACHING)
    # as a registry from before this fix holds it: the assessment's own proposal
    registry.record_proposal(assessment.trial_id, {
        "assistance_level": 1.0, "duration_s": 4.0, "tolerance_rad": 0.349,
        "change": "none", "reason": "transparent mode: the same again"})
    status, out, err = run(["trials", code], capsys)
    assert status == 0, err
    rows = out.splitlines()
    (row,) = [r for r in rows if r.startswith(f"{assessment.trial_id:>5} ")]
    assert "assessment: reaching" in row
    assert "targets r" not in row
    assert "30.0/30.0" not in row  # no exercise figure for a task's protocol
    assert "transparent " in row  # the mode apart from the assistance column
    assert "transparent mode: the same again" not in out
    assert out.count("proposed:") == 1
    assert "proposed: exercise reason" in out
    assert f"figures: rehab assess show {code} --task reaching" in out
    (row,) = [r for r in rows if r.startswith(f"{exercise.trial_id:>5} ")]
    assert "2.0/3.0" in row


def test_an_old_registry_s_assessment_proposal_is_never_offered(registry):
    """A registry written before assessments stopped proposing holds a pending proposal
    after an assessment trial (kept as the console then kept it, record_proposal): the
    next exercise is offered the exercise's proposal, and decides it, not the task's."""
    code = _patient(registry)
    exercise = register(registry, code, {}, task="", parameters=EXERCISE)
    registry.record_proposal(exercise.trial_id, {
        "assistance_level": 0.5, "duration_s": 4.0, "tolerance_rad": 0.349,
        "change": "assistance", "reason": "exercise reason"})
    assessment = register(registry, code, {"vgr_reaction_time_s": 0.4}, parameters=REACHING)
    registry.record_proposal(assessment.trial_id, {
        "assistance_level": 1.0, "duration_s": 4.0, "tolerance_rad": 0.349,
        "change": "none", "reason": "transparent mode: the same again"})
    waiting = registry.pending_proposal(code)
    assert waiting.trial_id == exercise.trial_id
    assert waiting.proposal["reason"] == "exercise reason"
    after = register(registry, code, {}, task="", parameters=EXERCISE, finish=False)
    assert registry.proposal(exercise.trial_id).next_trial_id == after.trial_id
    assert registry.proposal(exercise.trial_id).decision == "kept"
    assert registry.proposal(assessment.trial_id).next_trial_id is None
