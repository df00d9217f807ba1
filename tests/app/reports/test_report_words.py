"""The report's Exercise line in the words the Assessments tab uses for the same trial
(seen in the window: the tab set up "trial 2 of 2: counter-clockwise", "5 laps of 4 s",
and the report of that trial said "5 repetitions of 4 s, …, anticlockwise")."""

from __future__ import annotations

import pytest

from app.reports.content import _exercise_text
from app.reports.plain_language import parameter_cautions
from core.assessment import TASKS
from core.assessment.protocol import protocol
from core.holdtasks import ROBOT_TASKS
from core.trial import THESIS_SUBJECT
from ui.tabs.assessments import protocol_words


def test_the_circle_s_second_way_is_named_as_its_protocol_names_it():
    spec = protocol("circle")
    for index, way in enumerate(spec.trials):
        line = _exercise_text(spec.parameters(THESIS_SUBJECT, index))
        assert line.endswith(f", {way}"), line
    ccw = THESIS_SUBJECT.replace(shape="circle", clockwise=False).to_dict()
    cw = THESIS_SUBJECT.replace(shape="circle", clockwise=True).to_dict()
    (caution,) = parameter_cautions(cw, ccw)
    assert "(counter-clockwise; before, clockwise)" in caution


@pytest.mark.parametrize("task", [t for t in TASKS if t not in ROBOT_TASKS])
def test_a_task_s_laps_are_said_as_the_tab_says_them(task):
    """A round visits every target once, a lap goes once round the path: the tab's words,
    in the report of a trial of the task."""
    parameters = protocol(task).parameters(THESIS_SUBJECT)
    line = _exercise_text(parameters)
    unit = "round" if parameters.shape == "targets" else "lap"
    plural = "s" if parameters.repetitions != 1 else ""
    said = f"{parameters.repetitions} {unit}{plural} of {parameters.duration_s:g} s"
    assert said in line, line
    assert said in protocol_words(task)
    assert "repetition" not in line
