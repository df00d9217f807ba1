"""The session report (PDF) and the progress PDF's clinical scales (issue 31, item 4):
the session's trials with an invalid one saying why, its scales, its notes, and an
assessment's figures with Z-scores against hand-made norms, their source printed."""

from __future__ import annotations

import json

import pytest
from pypdf import PdfReader

from app.norms import load_norms
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress import progress
from app.reports.progress_pdf import write_progress_pdf
from app.reports.scales_progress import report_series
from app.reports.session_report import session_content, write_session_report
from core.trial import THESIS_SUBJECT
from tests.app.cli.running import run
from tests.app.exports.test_export import write
from tests.app.norms.handmade import handmade


def text_of(path) -> str:
    return " ".join(" ".join(page.extract_text().split()) for page in PdfReader(path).pages)


@pytest.fixture
def clinic(tmp_path, monkeypatch):
    monkeypatch.setenv("REHAB_DATA_DIR", str(tmp_path / "data"))
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", birth_year=1960, side="right",
                                   sex="female", handedness="right").code
    registry.open_session(code, therapist="K. Lee", location="room 2")
    exercise = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                    session_number=1)
    registry.finish_trial(exercise.trial_id, "complete", {"directional_performance_pct": 70.0})
    bad = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", session_number=1)
    registry.finish_trial(bad.trial_id, "complete", {"directional_performance_pct": 20.0})
    registry.mark_trial(bad.trial_id, valid=False, reason="let go of the handle", by="K. Lee")
    task = THESIS_SUBJECT.replace(repetitions=1, assessment="reaching")
    reach = registry.begin_trial(code, task, backend="simulator (healthy, seed 0)",
                                 session_number=1)
    write(reach.path, parameters=task, code=code)
    registry.finish_trial(reach.trial_id, "complete",
                          {"vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.40})
    registry.record_scale(code, 1, "fugl_meyer", parts={"A": 20, "B": 5, "C": 6, "D": 3},
                          rater="K. Lee")
    registry.record_scale(code, 1, "pain", total=2, rater="K. Lee")
    registry.add_note(code, 1, "tired after the second trial", author="K. Lee")
    registry.add_note(code, 1, "coughed at 12 s", author="K. Lee", trial_id=exercise.trial_id)
    return registry, code, tmp_path


def norms_file(tmp_path):
    # the trial files written here name no plant: their robot is "simulator", which the
    # hand-made norms get with no offset from their simulator-realistic
    document = handmade()
    document["covariates"]["robot"] = ["simulator-realistic", "simulator"]
    for figure in document["figures"].values():
        figure["coefficients"]["robot=simulator"] = 0.0
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(document))
    return load_norms(path)


def test_the_session_report_says_the_trials_scales_notes_and_z_scores(clinic):
    registry, code, tmp_path = clinic
    norms = norms_file(tmp_path)
    content = session_content(registry, code, 1, norms=norms)
    assert [row[-1] for row in content.trials] == [
        "valid", "INVALID: let go of the handle (K. Lee)", "valid"]
    (assessment,) = content.assessments
    reaction = next(r for r in assessment.rows if r.label.lower().startswith("reaction"))
    # by hand (tests/app/norms/test_model.py's formula): t = (√0.49 − 1)/0.5 = −0.6,
    # expected −1 + 0.01·66 (age in 2026) = −0.34, z = (−0.6 + 0.34)/0.1 = −2.6
    who_year = registry.session(code, 1).date.year
    expected = ((0.49 ** 0.5 - 1) / 0.5 - (-1 + 0.01 * (who_year - 1960))) / 0.1
    assert reaction.z.startswith(f"Z {expected:+.2f}"), assessment.notes
    assert "task score" in assessment.task_score
    speed = next(r for r in assessment.rows if r.label == "Max speed")
    assert speed.value == "400 mm/s"  # in the trial page's unit, not 0.4 m/s

    path = write_session_report(registry, code, 1, tmp_path / "session.pdf", norms=norms)
    text = text_of(path)
    for words in ("Session 1 of", "therapist K. Lee", "INVALID: let go of the handle",
                  "Fugl-Meyer UE motor: 34/66", "Pain (NRS): 2/10",
                  "tired after the second trial", "coughed at 12 s",
                  "Norms: hand-made for the tests", f"Z {expected:+.2f}"):
        assert words in text, words


def test_figures_the_norms_left_out_are_said_once_per_reason_without_their_source(clinic):
    """The session report printed "the norms (<their source>) hold no figure …: why" for
    each figure the fit left out: with the shipped norms, their 300-character source three
    times under the line that prints it once. One note per reason, as the assessment's own
    page says it."""
    registry, code, tmp_path = clinic
    document = handmade()
    document["source"] = "Clinic X, 120 healthy adults 21-84 y, measured 2026"
    document["covariates"]["robot"] = ["simulator-realistic", "simulator"]
    for figure in document["figures"].values():
        figure["coefficients"]["robot=simulator"] = 0.0
    document["notes"] = ("Left out by the fit:\n"
                         "vgr_initial_speed_ratio: every control has the same value\n"
                         "vgr_no_reaction_count: every control has the same value")
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(document))
    task = THESIS_SUBJECT.replace(repetitions=1, assessment="reaching")
    reach = registry.begin_trial(code, task, backend="simulator (healthy, seed 0)",
                                 session_number=1)
    write(reach.path, parameters=task, code=code)
    registry.finish_trial(reach.trial_id, "complete", {
        "vgr_reaction_time_s": 0.49, "vgr_max_speed_m_s": 0.40,
        "vgr_initial_speed_ratio": 1.0, "vgr_no_reaction_count": 0.0})
    content = session_content(registry, code, 1, norms=load_norms(path))
    notes = [note for a in content.assessments for note in a.notes]
    assert notes.count("no Z-score for Initial speed ratio, No reaction: every control has "
                       "the same value") == 1, notes
    assert not [note for note in notes if "Clinic X" in note]
    assert content.norms_label == "Norms: Clinic X, 120 healthy adults 21-84 y, measured 2026"


def test_the_report_scores_with_the_arm_the_trial_file_says(clinic):
    """The registry's side corrected after the trial (right → left): the report scores with
    the arm the trial's file recorded, as `rehab norms score` and `assess show` do
    (tests/app/norms/handmade.py: a left arm adds 0.02 to the expected value, Z −0.2)."""
    registry, code, tmp_path = clinic
    assert THESIS_SUBJECT.side == "right"
    registry.correct_patient(code, "side", "left", reason="entered wrong", by="K. Lee")
    (assessment,) = session_content(registry, code, 1, norms=norms_file(tmp_path)).assessments
    reaction = next(r for r in assessment.rows if r.label.lower().startswith("reaction"))
    who_year = registry.session(code, 1).date.year
    expected = ((0.49 ** 0.5 - 1) / 0.5 - (-1 + 0.01 * (who_year - 1960))) / 0.1
    assert reaction.z.startswith(f"Z {expected:+.2f}"), assessment.notes


def test_without_norms_or_covariates_the_report_says_why_no_z(clinic):
    registry, code, tmp_path = clinic
    assert "No norms in use" in session_content(registry, code, 1).norms_label
    registry.correct_patient(code, "sex", None, reason="not known", by="K. Lee")
    content = session_content(registry, code, 1, norms=norms_file(tmp_path))
    assert "sex is not recorded" in content.assessments[0].notes[0]
    assert all(r.z == "" for r in content.assessments[0].rows)


def test_norms_of_another_robot_are_said_once(clinic):
    """Norms whose controls used another robot: the assessment says why once (in the task
    score's place), not as a note and again in the task score."""
    registry, code, tmp_path = clinic
    document = handmade()
    document["covariates"]["robot"] = ["hardware"]
    path = tmp_path / "hardware.json"
    path.write_text(json.dumps(document))
    (assessment,) = session_content(registry, code, 1, norms=load_norms(path)).assessments
    said = [*assessment.notes, assessment.task_score]
    assert sum("hold no healthy people with robot" in text for text in said) == 1, said
    assert all(r.z == "" for r in assessment.rows)


def test_the_progress_pdf_ends_with_the_clinical_scales(clinic):
    registry, code, tmp_path = clinic
    registry.open_session(code)
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", session_number=2)
    registry.finish_trial(begun.trial_id, "complete", {"directional_performance_pct": 80.0})
    registry.record_scale(code, 2, "fugl_meyer", total=40, rater="M. Roy")
    prog = progress(registry, code, check_files=False)
    series = report_series(registry, prog)
    assert [(s.figure_key, s.scale_key, len(s.points)) for s in series] == [
        ("directional_performance_pct", "fugl_meyer", 2),
        ("directional_performance_pct", "pain", 1)]
    path = write_progress_pdf(prog, tmp_path / "progress.pdf",
                              scales=registry.session_scales(code), series=series)
    text = text_of(path)
    assert "Clinical scales of" in text
    assert "Fugl-Meyer UE motor: 40/66 — M. Roy" in text
    assert "n = 2" in text


def test_the_progress_pdf_says_which_changes_are_real_against_which_norms(clinic):
    """The window marks a change beyond the norms' MDC95 and names the norms; the PDF said
    nothing of it (a series judged against norms has no note, and only the note was
    printed)."""
    from app.reports.scales_progress import scale_series

    registry, code, tmp_path = clinic
    for number, (rt, fm) in enumerate(((0.45, 25), (0.30, 33)), start=2):
        registry.open_session(code)
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                     session_number=number)
        registry.finish_trial(begun.trial_id, "complete", {"vgr_reaction_time_s": rt})
        registry.record_scale(code, number, "fugl_meyer", total=fm, rater="K. Lee")
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(handmade()))  # the reaction time's MDC95: 0.08 s
    norms = load_norms(path)
    # session 1: 0.49 s (the fixture's reach), then 0.45 (not beyond 0.08), then 0.30
    series = scale_series(registry, code, "vgr_reaction_time_s", "fugl_meyer", norms=norms)
    assert [p.real_change for p in series.points] == [None, False, True]
    prog = progress(registry, code, check_files=False)
    pdf = write_progress_pdf(prog, tmp_path / "progress.pdf",
                             scales=registry.session_scales(code), series=(series,))
    text = text_of(pdf)
    assert "a real change (beyond MDC95 0.08) at session 3" in text
    assert "Norms: hand-made for the tests" in text


def test_the_progress_pdf_on_the_command_line_uses_the_norms_in_use(clinic, capsys):
    """`rehab progress CODE --pdf` with norms in use said "No norms in use: no change is
    marked real." under every figure against a scale."""
    registry, code, tmp_path = clinic
    path = tmp_path / "norms.json"
    path.write_text(json.dumps(handmade()))
    assert run(["norms", "use", str(path)], capsys)[0] == 0
    registry.open_session(code)
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator", session_number=2)
    registry.finish_trial(begun.trial_id, "complete", {"directional_performance_pct": 80.0})
    registry.record_scale(code, 2, "fugl_meyer", total=40, rater="M. Roy")
    status, _, err = run(["progress", code, "--pdf", str(tmp_path / "progress.pdf")], capsys)
    assert status == 0, err
    text = text_of(tmp_path / "progress.pdf")
    assert "No norms in use" not in text
    assert "hold no MDC95 for Direction" in text


def test_a_figure_against_a_scale_of_one_session_is_a_line_not_a_plot(clinic):
    """Clinic exploration 2 #5: a patient with one session had a page of single-point plots
    ("n = 1") per figure and scale; a plot of one point says nothing, so it is one line."""
    registry, code, tmp_path = clinic
    prog = progress(registry, code, check_files=False)
    series = report_series(registry, prog)
    assert series
    assert all(len(s.points) == 1 for s in series)
    path = write_progress_pdf(prog, tmp_path / "progress.pdf",
                              scales=registry.session_scales(code), series=series)
    text = text_of(path)
    assert "n = 1" not in text
    for s in series:
        assert f"{s.figure_label} against {s.scale_label}: session 1 only" in text
    assert "plotted from a second session with both" in text
    without = write_progress_pdf(prog, tmp_path / "bare.pdf")
    assert len(PdfReader(path).pages) == len(PdfReader(without).pages) + 1


def test_the_session_report_on_the_command_line(clinic, capsys):
    _, code, _ = clinic
    status, out, _ = run(["session-report", code, "1"], capsys)
    assert status == 0
    assert out.strip().endswith(f"{code}_S001_session.pdf")
    status, _, err = run(["session-report", code, "1"], capsys)
    assert status == 2
    assert "already exists" in err
    status, _, err = run(["session-report", code, "9"], capsys)
    assert status == 2
    assert "has no session 9" in err


def test_the_circles_two_trials_show_their_task_once(clinic):
    """Both circle trials hold the task's figures (each way's and their mean): the report
    shows them once, for trials 4 and 5, not the same table twice; a task's trials with
    figures of their own stay apart."""
    from app.reports.session_report import Assessment, AssessmentRow, one_per_task_result

    registry, code, tmp_path = clinic
    figures = {"circle_ratio": 0.9, "circle_sparc": -3.5, "circle_ratio_cw": 0.88,
               "circle_ratio_ccw": 0.92}
    for clockwise in (True, False):
        task = THESIS_SUBJECT.replace(repetitions=1, assessment="circle", shape="circle",
                                      clockwise=clockwise)
        trial = registry.begin_trial(code, task, backend="simulator (weak, seed 0)",
                                     session_number=1)
        write(trial.path, parameters=task, code=code)
        registry.finish_trial(trial.trial_id, "complete", figures)
    content = session_content(registry, code, 1)
    circle = [a for a in content.assessments if a.task_title.lower().startswith("circle")]
    assert len(circle) == 1
    assert circle[0].trial_numbers == (4, 5)
    assert circle[0].trials_text == "Trials 4 and 5"
    text = text_of(write_session_report(registry, code, 1, tmp_path / "s.pdf"))
    assert "Trials 4 and 5: Circle drawing" in text
    row = AssessmentRow("Reaction time", "0.4 s", "")
    one, other = (Assessment((n,), "Visually guided reaching", (replace_value(row, v),), "")
                  for n, v in ((1, "0.4 s"), (2, "0.5 s")))
    assert one_per_task_result([one, other]) == (one, other)


def replace_value(row, value):
    from dataclasses import replace

    return replace(row, value=value)


def test_the_assessment_page_names_the_fields_not_recorded(clinic):
    """Seen in the window: a patient registered with a year of birth, without sex or
    handedness, and the Assessments tab said "the patient's year of birth, sex or
    handedness is not recorded": the therapist who typed the year looked for a fault.
    The page, and the session report, name the fields missing."""
    from app.reports.assessment_page import patient_page

    registry, code, tmp_path = clinic
    for field in ("sex", "handedness"):
        registry.correct_patient(code, field, None, reason="not known", by="K. Lee")
    (note, *_) = patient_page(registry, code, "reaching").notes
    assert note == ("the patient's sex and handedness are not recorded: no Z-scores (record "
                    "them on the Registration tab: Clinical record, Correct)")
    (session_note, *_) = session_content(registry, code, 1,
                                         norms=norms_file(tmp_path)).assessments[0].notes
    assert session_note.startswith("no Z-scores: the patient's sex and handedness are not "
                                   "recorded"), session_note
