"""The built-in plan templates (resources/plans) are plans the console runs, and a damaged
or unknown one is refused in one line."""

import pytest

from app.plans.templates import TemplateError, load_template, template_names
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
