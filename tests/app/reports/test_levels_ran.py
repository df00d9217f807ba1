"""Issue 27 #5 (the report's side): the report, the PDF and the Report tab say the levels
of assistance the trial RAN, a change during it included ("100 % → 60 % at 2.0 s"), never
the level it was built with alone; and two trials whose help differed, or changed during
one of them, are not called better or worse than each other."""

from __future__ import annotations

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.build import content_for_registry_trial, report_for_registry_trial
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import page_texts, register, with_live_change

AS_NEEDED = THESIS_SUBJECT.replace(repetitions=2, assist="as-needed")


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    """Built at 100 % three times: held, then lowered to 60 % 2 s into the exercise, then
    held again; then built at 60 % twice."""
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Example", side="right").code
    at_60 = AS_NEEDED.replace(assistance_level=0.6)
    ids = {
        "held": register(registry, code, AS_NEEDED, session=1, seed=1),
        "lowered": register(registry, code, AS_NEEDED, session=1, seed=2, minutes=5,
                            edit=lambda trial: with_live_change(trial, 2.0, 0.6)),
        "after": register(registry, code, at_60, session=1, seed=3, minutes=10),
        "again": register(registry, code, at_60, session=1, seed=4, minutes=15),
    }
    return registry, ids, tmp_path_factory.mktemp("pdf")


def test_the_report_says_the_levels_the_trial_ran(course):
    registry, ids, folder = course
    assert read_trial(registry.trial_path(ids["lowered"])).assistance_timeline() == (
        (0.0, 1.0), (pytest.approx(2.0, abs=0.002), 0.6))
    pages = page_texts(report_for_registry_trial(registry, ids["lowered"],
                                                 folder / "lowered.pdf"))
    assert "100 % → 60 % at 2.0 s" in pages[0]
    assert "at 100 % → 60 % at 2.0 s (built at 100 %)" in pages[1]
    help_page = next(page for page in pages if "The help the robot learned" in page)
    assert "the assistance level ran at 100 % → 60 % at 2.0 s" in help_page
    content = content_for_registry_trial(registry, ids["lowered"])
    patient = {item.label: item.value for item in content.header}
    therapist = {item.label: item.value for item in content.therapist_header}
    assert patient["Robot's help"].startswith("100 % → 60 % at 2.0 s")
    assert "as-needed assistance at 100 % → 60 % at 2.0 s (built at 100 %)" in \
        therapist["Settings"]


def test_the_report_names_the_level_and_the_help_s_work_apart(course):
    """The report's header said "Robot's help 100 %" (the level) and its table "Robot's
    help −0.22 J" (the work of the robot's pull on the hand): one name for two figures. The
    table's row names the work, and no name of the header is a row's."""
    registry, ids, _ = course
    content = content_for_registry_trial(registry, ids["held"])
    header = {item.label for item in (*content.header, *content.therapist_header)}
    rows = {row.label: row for row in content.table}
    assert "Robot's help" in header
    assert not header & set(rows)
    assert rows["Work of the robot's help"].unit == "J"


def test_help_changed_during_a_trial_is_not_compared(course):
    registry, ids, _ = course
    lowered = content_for_registry_trial(registry, ids["lowered"])
    (comparison,) = lowered.comparisons  # with "held", the same settings as built
    assert {change.verdict for change in comparison.changes} == {""}
    assert not comparison.comparable
    assert comparison.cautions == (
        "The robot's help was different (100 % → 60 % at 2.0 s; before, 100 %), so the "
        "figures do not compare directly.",)
    # the next trial ran 60 % throughout: the one before it changed mid-way
    after = content_for_registry_trial(registry, ids["after"])
    assert not after.comparisons[0].comparable
    assert "before, 100 % → 60 % at 2.0 s" in after.comparisons[0].cautions[0]
    # two trials at 60 % held throughout compare
    again = content_for_registry_trial(registry, ids["again"])
    assert again.comparisons[0].comparable
    assert all(change.verdict for change in again.comparisons[0].changes)
