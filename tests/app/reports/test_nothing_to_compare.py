"""A report with nothing like it to compare with says so truly (seen in the window: a
patient's third trial of the day, a reach after a D and a circle, read "There is no earlier
trial to compare with yet"; the trials compared are those of the same exercise and mode,
app.reports.build.earlier_like)."""

from __future__ import annotations

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.build import report_for_registry_trial
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import page_texts, register

CIRCLE = THESIS_SUBJECT.replace(shape="circle", repetitions=1, assist="as-needed")
D = THESIS_SUBJECT.replace(repetitions=1, assist="as-needed")


def test_a_first_trial_of_an_exercise_after_others_is_not_called_the_first(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", side="right").code
    register(registry, code, CIRCLE, session=1, seed=1)
    d = register(registry, code, D, session=1, seed=2, minutes=5)
    page_one = page_texts(report_for_registry_trial(registry, d, tmp_path / "d.pdf"))[0]
    assert "There is no earlier trial" not in page_one  # the circle was earlier
    assert "No earlier trial of this exercise, with this kind of help from the robot, " \
           "to compare with yet." in page_one
