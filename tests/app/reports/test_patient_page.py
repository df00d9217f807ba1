"""Issue 27 #8: the patient's report (the PDF's page 1) is for the patient: the mode's own
success figure as its headline, no better-or-worse for a trial cut short or done at other
settings, the change in its own column, pages 1 and 2 agreeing, no instructions to the
therapist, coordinates, seeds or file names, every note printed, the path as the patient
sees it, and the robot credited where it did the work. Trials made by the simulator and
registered as the window registers them (tests/app/reports/made.py)."""

from __future__ import annotations

import dataclasses
import math
import re

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.build import content_for_registry_trial, report_for_registry_trial
from app.reports.compare import Baseline, compare, table_rows
from app.reports.pdf import NOTHING_TO_COMPARE
from app.reports.pdf_plots import path_plot
from app.reports.pdf_sheet import Sheet
from app.trials.assistance_timeline import AssistanceInEffect
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import cut, page_texts, placed_texts, register

AS_NEEDED = THESIS_SUBJECT.replace(repetitions=2, assist="as-needed")
THESIS = THESIS_SUBJECT.replace(repetitions=2)
VERDICTS = ("better", "worse", "the same", "more", "less")


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    """One patient: as-needed trials at one setting in sessions 1 and 2, then one ended by
    the emergency stop, then a thesis-mode trial."""
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Example", side="right").code
    ids = {
        "first": register(registry, code, AS_NEEDED, session=1, seed=1),
        "second": register(registry, code, AS_NEEDED, session=2, seed=2, minutes=60),
        "third": register(registry, code, AS_NEEDED, session=2, seed=3, minutes=70),
        "estop": register(registry, code, AS_NEEDED, session=2, seed=4, minutes=80,
                          edit=lambda trial: cut(trial, 0.4, "faulted")),
        "thesis": register(registry, code, THESIS, session=2, seed=5, minutes=90),
    }
    folder = tmp_path_factory.mktemp("reports")
    pdfs = {name: report_for_registry_trial(registry, ids[name], folder / f"{name}.pdf")
            for name in ("third", "estop", "thesis")}
    return registry, ids, pdfs


def test_the_headline_is_the_mode_s_own_success_figure(course):
    registry, ids, pdfs = course
    as_needed = content_for_registry_trial(registry, ids["third"])
    led = round(as_needed.metrics.led_pct)
    assert as_needed.plain[0].text == f"You led the movement {led} % of the time."
    thesis = content_for_registry_trial(registry, ids["thesis"])
    pushed = round(thesis.metrics.directional_performance_pct)
    assert thesis.plain[0].text == f"You pushed in the right direction {pushed} % of the time."
    for name, headline in (("third", as_needed.plain[0].text),
                           ("thesis", thesis.plain[0].text)):
        page = page_texts(pdfs[name])[0]
        after = page.split("How it went", 1)[1]
        assert after.lstrip().startswith(headline)
    # the as-needed page does not call the force's direction the patient's figure
    assert "right direction" not in page_texts(pdfs["third"])[0]
    # the therapist's table starts with the same figure
    assert as_needed.table[0].key == "led_pct"
    assert thesis.table[0].key == "directional_performance_pct"


def test_a_trial_cut_short_gets_no_verdict_on_either_page(course):
    registry, ids, pdfs = course
    patient, therapist = page_texts(pdfs["estop"])[:2]
    since = patient.split("Since last time", 1)[1]
    for word in VERDICTS:
        assert word not in since, word
    assert "↑" not in since
    assert "↓" not in since
    assert "not compared" in since
    assert "did not run to its end" in since
    table = therapist.split("Every figure of this trial", 1)[1]
    for word in ("better", "worse", "same", "more", "less", "↑", "↓"):
        assert f" {word}" not in table.split("Notes")[0], word
    assert "not compared" in table
    content = content_for_registry_trial(registry, ids["estop"])
    assert content.status == "faulted"
    assert content.comparisons
    assert not any(c.comparable for c in content.comparisons)


def test_a_trial_is_compared_only_with_trials_of_its_own_mode(course):
    """The thesis-mode trial follows as-needed ones of the same shape: another mode,
    another success figure, nothing to compare with."""
    registry, ids, pdfs = course
    since = page_texts(pdfs["thesis"])[0].split("Since last time", 1)[1]
    # not "no earlier trial": the as-needed ones were earlier
    assert since.lstrip().startswith(NOTHING_TO_COMPARE)
    assert content_for_registry_trial(registry, ids["thesis"]).comparisons == ()
    # given one anyway, the comparison says so and has no verdict
    thesis = content_for_registry_trial(registry, ids["thesis"])
    as_needed = content_for_registry_trial(registry, ids["third"])
    comparison = compare("previous trial", Baseline(
        as_needed.metrics.to_dict(), AS_NEEDED.to_dict(), 2, 2, levels=as_needed.levels),
        thesis.metrics.to_dict(), THESIS, levels=thesis.levels)
    assert not comparison.comparable
    assert any("another kind of help" in c for c in comparison.cautions)
    assert {c.verdict for c in comparison.changes} == {""}


def test_the_change_sits_in_its_own_column_not_under_the_earlier_trial(course):
    registry, ids, pdfs = course
    content = content_for_registry_trial(registry, ids["third"])
    placed = placed_texts(pdfs["third"], 0)
    changes = [x for x, _, text in placed if text.startswith("Change since")]
    earlier = [x for x, _, text in placed if text.startswith("Last")]  # may wrap
    assert len(changes) == 2
    assert len(earlier) == 2
    arrows = [x for x, _, text in placed if text[0] in "↑↓="]  # "↑ better" or "↑", "better"
    assert len(arrows) == 2 * len(content.comparisons[0].changes)
    for x in arrows:
        assert x in changes  # under a "Change since …" heading, never an earlier trial's
    # the earlier values sit under their trials' headings, left of "This trial"
    this_trial = next(x for x, _, text in placed if text == "This trial")
    assert all(x < this_trial for x in earlier)
    assert [c.comparable for c in content.comparisons] == [True, True]


def test_pages_one_and_two_agree(course):
    registry, ids, pdfs = course
    for name in ("third", "estop"):
        # in print: a figure page 1 calls better, worse or the same, page 2 calls so too
        patient, therapist = page_texts(pdfs[name])[:2]
        for label, row in (("Led the movement", "Led the movement (%)"),
                           ("Shoulder movement", "Shoulder range of motion (ISB) (°)"),
                           ("Elbow movement", "Elbow range of motion (ISB) (°)")):
            said = re.findall(rf"{label} [^A-Z]*", patient.split("Since last time", 1)[1])
            words = {w for w in VERDICTS if said and w in said[0]}
            cells = re.findall(rf"{re.escape(row)} [^A-Z]*", therapist)
            table = {w for w in ("better", "worse", "same", "more", "less")
                     if cells and w in cells[0]}
            assert {w.removeprefix("the ") for w in words} == table, (name, label)
        content = content_for_registry_trial(registry, ids[name])
        rows = {row.key: row for row in content.table}
        therapist = page_texts(pdfs[name])[1]
        for column, comparison in enumerate(content.comparisons):
            for change in comparison.changes:
                assert rows[change.key].verdicts[column] == change.verdict
                if change.verdict:
                    assert rows[change.key].earlier_texts[column].endswith(
                        f"{change.arrow} {change.verdict}")
            assert ("not compared" in content.table_columns[column]) == \
                (not comparison.comparable)
        assert ("not compared" in therapist) == (name == "estop")


FIGURES = st.fixed_dictionaries({
    "led_pct": st.floats(0, 100), "directional_performance_pct": st.floats(0, 100),
    "shoulder_rom_rad": st.floats(0, 2), "elbow_rom_rad": st.floats(0, 2),
    "rmse_x_m": st.floats(0, 0.05), "rmse_y_m": st.floats(0, 0.05),
})


@settings(max_examples=200, deadline=None)
@given(before=FIGURES, after=FIGURES, mode=st.sampled_from(["as-needed", "thesis"]),
       partial=st.booleans(), level_before=st.sampled_from([0.6, 1.0]),
       level_after=st.sampled_from([0.6, 1.0]))
def test_the_two_pages_give_every_figure_the_same_verdict(before, after, mode, partial,
                                                          level_before, level_after):
    """Whatever the figures, the trial's end and the help: each figure on the patient's
    page has the therapist's table's verdict in the same comparison, '' on both when the
    trials do not compare."""
    parameters = THESIS_SUBJECT.replace(assist=mode, assistance_level=level_after)
    baseline = Baseline(before, THESIS_SUBJECT.replace(assist=mode).to_dict(), 1, 1,
                        levels=AssistanceInEffect(((0.0, level_before),)))
    comparison = compare("previous trial", baseline, after, parameters, partial=partial,
                         levels=AssistanceInEffect(((0.0, level_after),)))
    assert comparison.comparable == (not partial and level_before == level_after)
    rows = {row.key: row for row in table_rows(after, (baseline,), mode=mode,
                                               comparable=(comparison.comparable,))}
    assert comparison.changes
    for change in comparison.changes:
        assert rows[change.key].verdicts == (change.verdict,)
        assert bool(change.verdict) == comparison.comparable


def test_the_patient_page_has_no_instructions_coordinates_seeds_or_file_names(course):
    _, _, pdfs = course
    patient, therapist = page_texts(pdfs["estop"])[:2]
    for text in ("Clear fault", "Make sure", "seed", ".h5", "trial file", "Settings"):
        assert text not in patient, text
    assert not re.search(r"\(-?\d+(\.\d+)?, -?\d+(\.\d+)?\)", patient)  # no (x, y)
    # no axis ticks either: every bare number on the page is a label's, with its unit
    for _, _, text in placed_texts(pdfs["estop"], 0):
        assert not re.fullmatch(r"[−-]?\d+(\.\d+)?", text), text
    assert "stopped with the emergency stop after" in patient
    # the therapist's page keeps the detail
    assert "Make sure the patient is safe, then press Clear fault" in therapist
    assert "seed 4" in therapist
    assert "centre (-30.0, 30.0) cm" in therapist


def test_the_therapist_s_pages_give_each_fault_once(course):
    """The fault stood in the therapist's header and again as the first note ('Fault at
    4.48 s: Emergency stop pressed …'): one fault read as two."""
    _, _, pdfs = course
    therapist = " ".join(page_texts(pdfs["estop"])[1:])
    assert therapist.count("Emergency stop pressed") == 1


def test_every_note_is_printed_and_none_is_pointed_at_elsewhere(course, tmp_path):
    registry, ids, _ = course
    content = content_for_registry_trial(registry, ids["third"])
    notes = tuple(f"note number {k} about this trial, long enough to take a line of "
                  "its own on the page" for k in range(90))
    from app.reports.build import write_report_pdf
    pdf = write_report_pdf(dataclasses.replace(content, notes=notes), tmp_path / "n.pdf")
    text = " ".join(page_texts(pdf))
    assert "more note" not in text
    for k in range(90):
        assert f"note number {k} about" in text


def test_the_path_is_drawn_as_the_patient_sees_it(course):
    """docs/frames.md: the patient sits on +y facing −y, their right is −x. Seen from
    their seat, a point nearer them is lower on the page, one to their right further
    right; the page draws no coordinates."""
    registry, ids, _ = course
    figure = content_for_registry_trial(registry, ids["third"]).path
    sheet = Sheet()
    path_plot(sheet, figure)
    (ax,) = sheet.fig.axes
    centre = np.mean(figure.outline_m, axis=0)

    def on_page(dx, dy):
        return ax.transData.transform(centre + np.array([dx, dy]))

    nearer, farther = on_page(0.0, +0.05), on_page(0.0, -0.05)
    assert nearer[1] < farther[1]  # nearer the patient: lower on the page
    right, left = on_page(-0.05, 0.0), on_page(+0.05, 0.0)
    assert right[0] > left[0]  # the patient's right (−x): right on the page
    assert not ax.get_xticks().size
    assert not ax.get_yticks().size


def test_the_robot_gets_the_credit_where_it_did_the_work(course):
    registry, ids, pdfs = course
    content = content_for_registry_trial(registry, ids["third"])
    lines = {line.key: line for line in content.plain}
    distance = math.hypot(content.metrics.rmse_x_m, content.metrics.rmse_y_m) * 1000
    assert lines["rmse"].text == (f"The robot kept your hand on average "
                                  f"{max(1, round(distance))} mm from the moving ring.")
    share = content.metrics.robot_work_share
    assert lines["robot_work_share"].text.startswith(
        f"You did {round(100 - 100 * share)} % of the work of moving the handle")
    patient = page_texts(pdfs["third"])[0]
    assert "Your hand kept" not in patient
    # the path is coloured by what the headline counts: where the patient led
    assert "you led" in patient
    assert "the robot helped you along" in patient
    assert "pushing the right way" not in patient
    # the distance from the path, the robot's doing, is no change of the patient's
    assert "rmse" not in {c.key for c in content.comparisons[0].changes}
