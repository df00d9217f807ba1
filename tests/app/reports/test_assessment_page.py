"""A task's report page (app.reports.assessment_page): every figure of the trial with its
label and unit, its Z-score and the task score against a hand-made normative file equal to
the norms' own, the norms' source printed (and 'simulated' when they are), and the PDF
written."""

import datetime
import json
import math

import pytest

from app.norms import Covariates, load_norms
from app.reports.assessment_page import (
    NO_NORMS,
    assessment_page,
    covariates,
    figure_text,
    page_text,
    write_assessment_pdf,
)
from core.assessment import task_figures
from tests.app.norms.handmade import handmade

PERSON = Covariates(age_years=60, sex="male", handedness="right", tested_side="left",
                    robot="simulator-realistic")
METRICS = {"vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.3, "vgr_sparc": -1.6,
           "vgr_no_reaction_count": 2.0, "vgr_speed_maxima_count": 1.6875,
           "vgr_movement_time_s": math.nan, "rmse_m": 0.01}


@pytest.fixture
def norms(tmp_path):
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(handmade()))
    return load_norms(path)


def test_the_figures_in_the_catalogues_order_with_their_units():
    page = assessment_page("reaching", METRICS)
    keys = [line.key for line in page.lines]
    order = [spec.key for spec in task_figures("reaching")]
    assert keys == [k for k in order if k in METRICS]  # not rmse_m: no reaching figure
    values = {line.key: line.value for line in page.lines}
    assert values["vgr_reaction_time_s"] == "0.49 s"
    assert values["vgr_no_reaction_count"] == "2"
    assert values["vgr_speed_maxima_count"] == "1.69"  # a mean over the reaches
    assert values["vgr_movement_time_s"] == "not defined"
    assert page.norms == NO_NORMS
    assert all(line.z is None for line in page.lines)


def test_the_figures_read_in_the_units_of_the_rest_of_the_report_not_si():
    """Trying the window: the reaching page said 0.0008121 m/s and 0.04029 rad where the
    trial's page beside it (and the window) say mm/s and degrees (app.units)."""
    page = assessment_page("reaching", {"vgr_posture_speed_m_s": 0.0008121,
                                        "vgr_initial_direction_error_rad": 0.04029,
                                        "vgr_max_speed_m_s": 0.3323})
    values = {line.key: line.value for line in page.lines}
    # in each unit's decimals, as the report's rows write them (MetricRow.places; four
    # significant digits wrote "332.3 mm/s" where the report wrote 332), the posture
    # speed, about 1 mm/s, to a tenth
    assert values == {"vgr_posture_speed_m_s": "0.8 mm/s",
                      "vgr_initial_direction_error_rad": "2.3°",
                      "vgr_max_speed_m_s": "332 mm/s"}
    position = assessment_page("position", {"position_absolute_error_m": 0.0125})
    assert [line.value for line in position.lines] == ["12.5 mm"]
    area = assessment_page("range", {"range_area_m2": 0.0412})
    assert [line.value for line in area.lines] == ["412 cm²"]


def test_without_the_patients_covariates_the_page_says_where_to_record_them(norms):
    """Trying the window: the Assessments tab told the therapist to run
    "rehab patients ... --sex --handedness" (a command that registers a new patient)."""
    page = assessment_page("reaching", METRICS, norms=norms, person=None)
    (note,) = [n for n in page.notes if "not recorded" in n]
    assert "no Z-scores" in note
    assert "Registration tab: Clinical record, Correct" in note
    assert "rehab " not in note


def test_z_scores_and_the_task_score_are_the_norms(norms):
    page = assessment_page("reaching", METRICS, norms=norms, person=PERSON)
    z = {line.key: line.z for line in page.lines}
    assert z["vgr_reaction_time_s"] == pytest.approx(-2.7)  # tests/app/norms/test_model.py
    assert z["vgr_max_speed_m_s"] == pytest.approx(-1.6)
    assert z["vgr_sparc"] is None  # the norms do not hold it
    score = norms.task_score("reaching", METRICS, PERSON).score
    assert f"Task score {score:.2f}" in page.task_score
    assert page.norms == "Norms: hand-made for the tests, 3 Dec 2026"
    text = "\n".join(page_text(page))
    assert "Z -2.70" in text
    assert page.norms in text


def test_a_task_not_performed_says_so_on_the_page(norms):
    """The passive patient's reaching: no reaction in any reach — the page names it as the
    worst result, not as a figure the trial lacks."""
    still = {"vgr_reaction_time_s": math.nan, "vgr_max_speed_m_s": 0.0,
             "vgr_no_reaction_count": 16.0}
    page = assessment_page("reaching", still, norms=norms, person=PERSON)
    assert page.task_score == ("Task not performed: no reaction in any of the 16 reaches "
                               "(worse than any task score)")
    assert page.task_score in page_text(page)


def test_simulated_norms_say_so(tmp_path):
    document = handmade()
    document["simulated"] = True
    path = tmp_path / "sim.json"
    path.write_text(json.dumps(document))
    page = assessment_page("reaching", METRICS, norms=load_norms(path), person=PERSON)
    assert "simulated — for demonstration and tests only" in page.norms


def test_a_patient_without_sex_or_handedness_gets_no_z_and_is_told_why(norms):
    page = assessment_page("reaching", METRICS, norms=norms, person=None)
    assert all(line.z is None for line in page.lines)
    assert any("not recorded" in note for note in page.notes)


def test_the_covariates_come_from_the_registry_and_the_trials_robot():
    class Patient:
        birth_year, sex, handedness, side = 1966, "male", "right", "left"

    who = covariates(Patient, datetime.date(2026, 12, 3), "simulator (healthy, seed 1)",
                     {"plant": "realistic"})
    assert who == PERSON
    Patient.sex = None
    assert covariates(Patient, datetime.date(2026, 12, 3), "simulator", {}) is None


def test_a_registry_without_the_side_scores_with_the_trial_files_side():
    """The registry lacks the tested side, the trial's file records it: Z-scores, with the
    file's arm (before, "the registry lacks … tested side" and none)."""
    class Patient:
        birth_year, sex, handedness, side = 1966, "male", "right", None

    when = datetime.date(2026, 12, 3)
    robot = ("simulator (healthy, seed 1)", {"plant": "realistic"})
    assert covariates(Patient, when, *robot) is None
    assert covariates(Patient, when, *robot, tested_side="left") == PERSON


def test_the_pdf_is_written(tmp_path, norms):
    page = assessment_page("reaching", METRICS, heading="P001, session 1", norms=norms,
                           person=PERSON)
    path = write_assessment_pdf(tmp_path / "assessment.pdf", [page])
    assert path.read_bytes().startswith(b"%PDF")


def test_the_circle_page_joins_the_latest_trial_each_way_round(tmp_path):
    from app.records.datadir import DataDir
    from app.records.registry import Registry
    from app.reports.assessment_page import patient_page
    from core.assessment.figures import CIRCLE_BASE_KEYS, circle_key
    from core.assessment.protocol import protocol
    from core.trial import TrialParameters

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Circle", side="right").code
    assert patient_page(registry, code, "circle") is None

    def circle(index, value):
        trial = protocol("circle").parameters(TrialParameters(), index)
        way = "cw" if trial.clockwise else "ccw"
        begun = registry.begin_trial(code, trial, backend="simulator (healthy, seed 1)")
        registry.finish_trial(begun.trial_id, "complete",
                              {circle_key(b, way): value for b in CIRCLE_BASE_KEYS})

    circle(0, 0.8)
    page = patient_page(registry, code, "circle")
    assert "one way round only" in page.heading
    assert {line.key for line in page.lines} == {circle_key(b, "cw") for b in CIRCLE_BASE_KEYS}
    circle(1, 0.6)
    page = patient_page(registry, code, "circle")
    values = {line.key: line.value for line in page.lines}
    assert values["circle_ratio"] == "0.70"  # the mean of the two ways
    assert values["circle_ratio_cw"] == "0.80"
    assert values["circle_ratio_ccw"] == "0.60"
    assert "with trial 1" in page.heading


def test_a_z_score_far_outside_the_controls_prints_as_a_bound(norms):
    """Beyond ±10 the controls' transform extrapolates (the passive patient's circle speed
    of 0 scored −6.7·10¹⁰ against the simulated norms): the page says "< −10"."""
    from app.norms.model import Z_SHOWN, z_text

    # untransformed max speed: expected 0.38 m/s, SD 0.05 (tests/app/norms/test_model.py)
    page = assessment_page("reaching", {"vgr_max_speed_m_s": 0.38 - 0.05 * 12},
                           norms=norms, person=PERSON)
    (line,) = page.lines
    assert line.z == pytest.approx(-12.0)
    assert figure_text(line).endswith("Z < −10")
    assert z_text(-Z_SHOWN) == "-10.00"
    assert z_text(10.004) == "> +10"
    assert z_text(-6.7e10) == "< −10"
    assert z_text(1.6) == "+1.60"


def test_the_pdf_marks_a_z_score_of_an_age_beyond_the_controls(norms):
    """The PDF's Z column is too narrow for "(age beyond the controls')": a † beside the
    Z-score and the words once under the table."""
    from app.reports.assessment_page import page_figure

    old = Covariates(90, "female", "right", "right", "simulator-realistic")
    drawn = page_figure(assessment_page("reaching", METRICS, norms=norms, person=old))
    cells = [c.get_text().get_text() for ax in drawn.axes for t in ax.tables
             for c in t.get_celld().values()]
    assert any(text.endswith(" †") for text in cells)
    words = "\n".join(t.get_text() for t in drawn.texts)
    assert "† age beyond the controls': the Z-score extrapolates the norms" in words
    young = page_figure(assessment_page("reaching", METRICS, norms=norms, person=PERSON))
    assert not any("†" in t.get_text() for t in young.texts)


def test_a_person_the_norms_do_not_hold_is_said_once(tmp_path):
    """Norms of another robot: the page says why once, not once per figure and again in
    the task score's place."""
    other = handmade()
    other["covariates"]["robot"] = ["hardware"]
    path = tmp_path / "hardware.json"
    path.write_text(json.dumps(other))
    page = assessment_page("reaching", METRICS, norms=load_norms(path), person=PERSON)
    why = "hold no healthy people with robot 'simulator-realistic'"
    said = [*page.notes, page.task_score]
    assert sum(why in text for text in said) == 1, said
    assert all(line.z is None for line in page.lines)


def test_a_task_score_far_outside_the_controls_prints_as_a_bound():
    """As a Z-score beyond ±10 (Z_SHOWN): 24 virtual controls' range norms (λ = −5) gave
    the passive patient's area a task score of 13184793.06, digits of the extrapolated
    transform that say nothing but 'far beyond every control'."""
    from app.norms.model import score_text

    assert score_text(1.7) == "1.70"
    assert score_text(10.0) == "10.00"
    assert score_text(13184793.06) == "> 10"
