"""The built-in plan templates (resources/plans) are plans the console runs, and a damaged
or unknown one is refused in one line."""

import numpy as np
import pytest

from app.plans.templates import TemplateError, load_template, template_names
from core.plan import check_plan
from core.trial import THESIS_SUBJECT
from core.trial_check import check_trial


def test_every_built_in_template_is_a_plan_whose_trials_the_robot_and_arm_reach():
    names = template_names()
    assert {"first-session", "reaching", "endurance", "games"} <= set(names)
    for name in names:
        template = load_template(name)
        assert template.about
        assert template.plan.blocks
        for block in template.plan.blocks:
            assert check_trial(block.parameters(THESIS_SUBJECT)).ok, (name, block)
        assert template.plan.blocks[-1].rest_s == 0.0  # no rest after the last block


@pytest.mark.parametrize(("text", "words"), [
    ("{", "cannot be read"),
    ('{"about": "x"}', "give an object with 'about'"),
    ('{"about": "x", "plan": {"name": "P", "blocks": [{"rest_s": NaN}]}}', "cannot be read"),
    ('{"about": "x", "plan": {"name": "P", "blocks": [{"rest_s": -5}]}}', "block 1.rest_s"),
    ("[" * 100000 + "]" * 100000, "cannot be read"),
    (b"\xff\xfe", "cannot be read"),
])
def test_a_damaged_template_is_refused_in_one_line_naming_its_file(tmp_path, text, words):
    path = tmp_path / "mine.json"
    if isinstance(text, bytes):
        path.write_bytes(text)
    else:
        path.write_text(text)
    with pytest.raises(TemplateError) as refused:
        load_template("mine", tmp_path)
    message = str(refused.value)
    assert words in message
    assert str(path) in message
    assert "\n" not in message


def test_an_unknown_template_is_refused_naming_the_ones_there_are():
    with pytest.raises(TemplateError, match="first-session"):
        load_template("nope")


# the arms a template is copied to: the virtual patients' (the thesis subject's, 12 + 12
# in), two registered in the console's examples, the one that met the refusal (57 cm), and
# a small and a large adult
ARMS = {
    "virtual patients": (THESIS_SUBJECT.upper_arm_m, THESIS_SUBJECT.forearm_m, 91.0),
    "examples 0.30 + 0.28": (0.30, 0.28, 70.0),
    "examples 0.31 + 0.28": (0.31, 0.28, 82.0),
    "reaching 57 cm": (0.30, 0.27, 70.0),
    "small adult": (0.26, 0.22, 48.0),
    "large adult": (0.37, 0.30, 110.0),
}


def _setup(upper_arm_m, forearm_m, mass_kg):
    """The patient at the Parameters tab's default centre, the shoulder brought as close
    as the form's D (its default exercise) needs: a setup the Parameters tab accepts."""
    for dy in np.arange(0.0, 0.30, 0.01):
        base = THESIS_SUBJECT.replace(upper_arm_m=upper_arm_m, forearm_m=forearm_m,
                                      body_mass_kg=mass_kg, shoulder_m=(-0.12, 0.73 - dy))
        if check_trial(base).ok:
            return base
    raise AssertionError("no shoulder fits the form's D")


@pytest.mark.parametrize("arm", ARMS)
def test_every_template_copied_to_a_patient_runs_for_them(arm):
    base = _setup(*ARMS[arm])
    for name in template_names():
        template = load_template(name, fit_to=base)
        assert check_plan(template.plan, base) == (), (arm, name, template.fitted)
        assert len(template.fitted) == sum(
            a.radius_m != b.radius_m for a, b in zip(template.plan.blocks,
                                                     load_template(name).plan.blocks,
                                                     strict=True))


def test_the_first_session_template_fits_the_arm_that_was_refused_and_says_what_changed():
    """The symptom: shoulder (-12, 73) cm, an arm reaching 57 cm; the reach block's far
    point went 57.9 cm from the shoulder and Start plan refused the plan."""
    base = THESIS_SUBJECT.replace(upper_arm_m=0.30, forearm_m=0.27, body_mass_kg=70.0)
    assert check_trial(base).ok  # the form's own exercise runs
    as_written = load_template("first-session").plan
    refusal = check_plan(as_written, base)
    assert refusal
    assert "block 3 (Forward reach)" in refusal[0]
    assert refusal[0].endswith("; at a radius of 0.05 m it fits.")  # what would, one line
    fitted = load_template("first-session", fit_to=base)
    assert check_plan(fitted.plan, base) == ()
    assert fitted.plan.blocks[:2] == as_written.blocks[:2]
    assert fitted.plan.blocks[2].radius_m < as_written.blocks[2].radius_m
    (line,) = fitted.fitted
    assert line.startswith("block 3 (Forward reach): radius ")
    assert "\n" not in line
