"""One display unit per quantity wherever a person reads it (app.units): the set-up's
positions in cm as the form shows them, the assistance in % as the form sets it."""

from app.reports.content import _settings_text
from app.reports.progress import ParameterSet
from app.units import assistance_percent, cm, point_cm
from core.trial import THESIS_SUBJECT


def test_the_helpers():
    assert cm(0.3) == "30.0 cm"
    assert point_cm((-0.12, 0.73)) == "(-12.0, 73.0) cm"
    assert assistance_percent(0.4) == "40 %"


def test_the_report_settings_line_uses_the_forms_units():
    text = _settings_text(THESIS_SUBJECT.replace(assistance_level=0.4))
    assert "assistance level 40 %" in text
    assert f"centre {point_cm(THESIS_SUBJECT.centre_m)}" in text
    assert " mm" not in text


def test_the_progress_label_says_assistance_in_percent():
    label = ParameterSet.of(THESIS_SUBJECT.to_dict()).label()
    assert "assistance 100 %" in label
    assert "assist 1.00" not in label
