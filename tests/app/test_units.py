"""One display unit per quantity wherever a person reads it (app.units): the set-up's
positions in cm as the form shows them, the assistance in % as the form sets it."""

import numpy as np

from app.records.assistance import AssistanceInEffect
from app.reports.content import _settings_text
from app.reports.progress_figure import help_staircase
from app.units import assistance_percent, cm, point_cm
from core.trial import THESIS_SUBJECT


def test_the_helpers():
    assert cm(0.3) == "30.0 cm"
    assert point_cm((-0.12, 0.73)) == "(-12.0, 73.0) cm"
    assert assistance_percent(0.4) == "40 %"


def test_the_report_settings_line_uses_the_forms_units():
    text = _settings_text(THESIS_SUBJECT.replace(assistance_level=0.4),
                          AssistanceInEffect(((0.0, 0.4), (5.8, 0.3))))
    assert "assistance at 40 % → 30 % at 5.8 s (built at 40 %)" in text
    assert f"centre {point_cm(THESIS_SUBJECT.centre_m)}" in text
    assert " mm" not in text


def test_progress_draws_the_assistance_in_percent():
    _, levels, _, live = help_staircase(np.array([1]), [AssistanceInEffect(((0.0, 0.4),
                                                                             (1.0, 0.3)))],
                                        np.array([2.0]))
    assert levels.tolist() == [40.0, 40.0, 30.0, 30.0]
    assert live.tolist() == [30.0]
