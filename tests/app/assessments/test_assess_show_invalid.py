"""`rehab assess show` leaves out the trials marked invalid (`rehab invalid`), as Progress,
the proposals and the exports do, and says in one line how many and how to see them;
with --include-invalid it shows them, each saying why. A circle pair with a trial marked
invalid has no task figures shown: they are the mean of both circles."""

from __future__ import annotations

from core.trial import THESIS_SUBJECT
from tests.app.assessments.registered import register
from tests.app.cli.running import run

REACHING = {"vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.3}
CIRCLE_WAY = {"circle_ratio": 0.9, "circle_joint_independence": 0.8, "circle_sparc": -3.0,
              "circle_ldlj": -15.0, "circle_mean_speed_m_s": 0.07}


def _circle_pair(registry, code) -> tuple[int, int]:
    """Two circle trials as app.assessments.runner registers them: each its own way's
    figures and the pair's (both ways and their mean)."""
    from app.assessments.figures import circle_task

    pair = circle_task(_way(CIRCLE_WAY, "cw"), _way({**CIRCLE_WAY, "circle_ratio": 0.8}, "ccw"))
    ids = []
    for clockwise in (True, False):
        begun = register(registry, code, pair, task="circle",
                         parameters=THESIS_SUBJECT.replace(clockwise=clockwise))
        ids.append(begun.trial_id)
    return ids[0], ids[1]


def _way(figures: dict, way: str) -> dict:
    from core.assessment.figures import circle_key

    return {circle_key(k, way): v for k, v in figures.items()}


def _invalid(trial_id: int, capsys) -> None:
    code, _, err = run(["invalid", str(trial_id), "--reason", "the patient coughed", "--by",
                        "TH"], capsys)
    assert code == 0, err


def test_an_invalid_trial_is_left_out_unless_asked(registry, capsys):
    code = registry.create_patient("Ada", "Example", side="right").code
    kept = register(registry, code, REACHING).trial_id
    spoilt = register(registry, code, REACHING).trial_id
    _invalid(spoilt, capsys)
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 0, err
    assert f"— trial id {kept}," in out
    assert f"— trial id {spoilt}," not in out
    assert ("1 trial(s) marked invalid left out (`rehab trials CODE` says why); "
            "--include-invalid shows them too") in out
    status, out, err = run(["assess", "show", code, "--include-invalid"], capsys)
    assert status == 0, err
    assert f"— trial id {kept}," in out
    assert f"— trial id {spoilt}," in out
    assert out.count("  invalid: the patient coughed") == 1
    assert "marked invalid left out" not in out  # (the norms' source says who else was)


def test_a_circle_pair_with_an_invalid_trial_shows_no_task_figures(registry, capsys):
    code = registry.create_patient("Ada", "Example", side="right").code
    cw, ccw = _circle_pair(registry, code)
    _invalid(ccw, capsys)
    status, out, err = run(["assess", "show", code], capsys)
    assert status == 0, err
    assert "  Circle ratio (cw): 0.9" in out
    assert "(ccw)" not in out
    assert "  Circle ratio: " not in out  # the mean of both: one of them is invalid
    assert "— both ways" not in out
    assert (f"  note: the task's figures (both ways round) are left out with trial {ccw}, "
            "marked invalid (--include-invalid shows them)") in out
    status, out, err = run(["assess", "show", code, "--include-invalid"], capsys)
    assert status == 0, err
    assert f"Circle drawing — both ways, from trial ids {cw} and {ccw} ({ccw} marked invalid)" \
        in out
    assert out.count("  Circle ratio: ") == 1
