"""A trial's gains line (core.control.gains): parsed, checked by the gains' own ranges,
kept canonical, saved with the trial and used by the tick."""

import pytest

from core.control.gains import built, canonical_gains, gain_rows, parse_gains
from core.control.guidance import GuidanceGains
from core.control.smc import SMCGains
from core.errors import ParameterError
from core.trial import THESIS_SUBJECT, TrialParameters
from device.loop.pipeline import TickPipeline, TrialPlan


def test_a_line_is_parsed_per_joint_and_kept_canonical():
    assert parse_gains("smc.lambda_1_s=25; smc.k_d_Nms_rad=3,4") == {
        "smc": {"lambda_1_s": (25.0, 25.0), "k_d_Nms_rad": (3.0, 4.0)}}
    assert canonical_gains(" guidance.bins = 10 ;smc.lambda_1_s=25\n") == (
        "guidance.bins=10; smc.lambda_1_s=25,25")
    assert TrialParameters(gains="smc.lambda_1_s=25") == TrialParameters(
        gains="smc.lambda_1_s=25,25")


@pytest.mark.parametrize(("line", "needle"), [
    ("lambda=3", "group.name=value"),
    ("pid.kp=3", "no gains called 'pid'"),
    ("smc.lambda=3", "a gain of smc"),
    ("smc.lambda_1_s=fast", "a number"),
    ("smc.lambda_1_s=nan", "finite"),
    ("smc.lambda_1_s=1,2,3", "one number for both joints, or two"),
    ("guidance.delay_s=1,2", "not per joint"),
    ("guidance.bins=2.5", "whole number"),
    ("smc.lambda_1_s=500", "smc.lambda_1_s[0]"),
    ("guidance.help_limit_N=-1", "guidance.help_limit_N"),
    ("smc.lambda_1_s=20; smc.lambda_1_s=25", "given twice"),
])
def test_a_bad_line_is_refused_by_name(line, needle):
    with pytest.raises(ParameterError, match="gains") as caught:
        TrialParameters(gains=line)
    assert needle in str(caught.value)


def test_a_non_text_line_is_refused():
    with pytest.raises(ParameterError, match="gains"):
        TrialParameters(gains=25)


def test_the_gains_travel_with_the_trial_and_run_its_tick():
    params = THESIS_SUBJECT.replace(assist="as-needed",
                                    gains="smc.lambda_1_s=30; guidance.delay_s=0.6")
    assert TrialParameters.from_dict(params.to_dict()) == params
    pipeline = TickPipeline(TrialPlan.build(params))
    assert pipeline.controller.gains == SMCGains(lambda_1_s=(30.0, 30.0))
    assert pipeline.guidance == GuidanceGains(delay_s=0.6)
    assert built("guidance", "") == GuidanceGains()


def test_every_gain_is_listed_with_its_default():
    rows = {name: default for name, default, *_ in gain_rows()}
    assert rows["smc.lambda_1_s"] == "20,20"
    assert rows["guidance.delay_s"] == "0.3"
    assert len(rows) == 4 + 4 + len(GuidanceGains.__dataclass_fields__) + 3  # transparent
