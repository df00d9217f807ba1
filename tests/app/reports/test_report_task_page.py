"""An assessment trial's post-trial report (app.reports.build): its task's page with the
task's figures (the registry's, as `rehab assess show` prints them), a line in the
therapist's header saying where they are and what the trial's own table measures, and no
distance from the task's moving reference on the patient's page (plain_language.
patient_mode); an exercise's report is as it was."""

from __future__ import annotations

from pypdf import PdfReader

from app.assessments.runner import run_task
from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.build import TASK_NOTE, content_for_registry_trial, write_report_pdf
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import register


def test_an_assessment_trials_report_carries_its_task_page(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Circle", birth_year=1960, side="right",
                                   sex="female", handedness="right").code
    cw, ccw = run_task("circle", "weak", seed=2, registry=registry, code=code)
    content = content_for_registry_trial(registry, ccw.trial_id)
    page = content.assessment
    assert page is not None
    assert page.title == "Circle drawing"
    values = {line.key: line.value for line in page.lines}
    assert values["circle_ratio"] == f"{ccw.figures['circle_ratio']:.2f}"  # a ratio's two
    assert values["circle_sparc_cw"] == f"{cw.figures['circle_sparc_cw']:.2f}"
    assert "trial 2" in page.heading
    # the data folder's norms in use (the shipped simulated ones): Z-scores and the label
    assert any(line.z is not None for line in page.lines)
    assert "simulated" in page.norms
    task_line = [h for h in content.therapist_header if h.label == "Task"]
    assert task_line[0].value == f"Circle drawing: {TASK_NOTE}"
    # the patient's page: no distance from the moving dot called a distance from the path
    # (the weak hand laps slower than the dot: "within 96 mm of the path" of a 7 cm circle)
    assert content.plain
    assert "rmse" not in {line.key for line in content.plain}
    for comparison in content.comparisons:
        assert "rmse" not in {change.key for change in comparison.changes}
    # nor the hand's path coloured by its push along the dot's clock (the healthy patient's
    # free reaches read "pushing another way" most of the time), nor a robot's share of the
    # work of a robot that only made itself lighter (plain_language.robot_only_lightened)
    assert content.path.runs == ()
    assert "robot_work_share" not in {row.key for row in content.table}
    assert "the robot did" not in " ".join(line.text for line in content.plain)
    path = write_report_pdf(content, tmp_path / "report.pdf")
    pages = [" ".join(p.extract_text().split()) for p in PdfReader(path).pages]
    assert "path to follow start your hand" in pages[0]  # the one line is named in the key
    assert "pushing another way" not in pages[0]
    assert "Circle drawing" in pages[-1]
    assert "Joint independence" in pages[-1]
    assert "its own figures lead the table below" in " ".join(pages)


def test_an_exercises_report_has_no_task_page(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Exercise", side="right").code
    registry.open_session(code)
    trial_id = register(registry, code, THESIS_SUBJECT.replace(repetitions=1), session=1)
    content = content_for_registry_trial(registry, trial_id)
    assert content.assessment is None
    assert content.plain[0].key == "directional_performance_pct"  # the thesis mode's
    # the therapist's table as it was: against the path, the mode's success figure first
    keys = [row.key for row in content.table]
    assert keys[0] == "directional_performance_pct"
    assert {"rmse_x_m", "rmse_y_m", "rmse", "path_length_ratio"} <= set(keys)
    assert content.force.caption.endswith("of the exercise time (directional performance)")
    assert not [h for h in content.therapist_header if h.label == "Task"]


def test_an_own_pace_task_s_therapist_table_is_its_own_figures(tmp_path):
    """The healthy patient's reaching task (at their own pace, not the targets' clock): the
    therapist's table read 'Position error' and 'Directional performance' against the
    task's reference, labelled as such, its own figures only on the last page. Now its own
    figures lead the table, in the units a person reads, and no row is measured against
    the reference; the joints' ranges and torques, the forces and the works stay."""
    from app.reports.task_table import REFERENCE_KEYS
    from core.assessment import task_figures

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Reach", birth_year=1960, side="right",
                                   sex="female", handedness="right").code
    (trial,) = run_task("reaching", "healthy", seed=3, registry=registry, code=code)
    content = content_for_registry_trial(registry, trial.trial_id)
    rows = {row.key: row for row in content.table}
    own = [f.key for f in task_figures("reaching") if f.key in trial.figures]
    assert [row.key for row in content.table][:len(own)] == own
    assert not REFERENCE_KEYS & set(rows)
    assert rows["vgr_max_speed_m_s"].unit == "mm/s"
    assert rows["vgr_max_speed_m_s"].value == trial.figures["vgr_max_speed_m_s"] * 1000.0
    assert rows["vgr_initial_direction_error_rad"].unit == "°"
    assert rows["vgr_path_length_ratio"].unit == ""
    assert "lower is better" in rows["vgr_path_length_ratio"].meaning
    assert {"shoulder_rom_rad", "elbow_rom_rad", "force_range_x_N"} <= set(rows)
    assert "sparc" not in rows  # the whole trial's, pauses and all: the task's per reach
    assert "patient_work_J" in rows
    assert "robot_help_work_J" not in rows  # none by design: the robot only lightened
    task_line = [h for h in content.therapist_header if h.label == "Task"]
    assert task_line[0].value == f"Visually guided reaching: {TASK_NOTE}"
    path = write_report_pdf(content, tmp_path / "report.pdf")
    therapist = " ".join(PdfReader(path).pages[1].extract_text().split())
    assert "Initial speed ratio" in therapist
    assert "Position error" not in therapist
    assert "directional performance" not in therapist.lower()  # nor Fig. 3.9's caption
    assert content.force.runs == ()
    assert "own pace" in content.force.caption
    # none drawn
    assert not [note for note in content.notes if "percentage counts every moment" in note]


def test_a_short_note_does_not_get_a_page_of_its_own(tmp_path):
    """The weak patient's reaching report: its therapist page's figure table filled the
    page and the one note went alone onto a 'For the therapist (continued)' page; the table
    is now drawn with tighter rows (app.reports.pdf.ROW_HEIGHTS_IN) so the note stays on
    the therapist's page: the patient's page, the therapist's, the task's. (Its one note
    was the path's runs', which a task the patient paces no longer draws: a note of that
    length stands in for it.)"""
    import dataclasses

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Reach", birth_year=1960, side="right",
                                   sex="female", handedness="right").code
    (trial,) = run_task("reaching", "weak", seed=5, registry=registry, code=code)
    content = content_for_registry_trial(registry, trial.trial_id)
    content = dataclasses.replace(content, notes=(*content.notes, (
        "In the drawings of the path and of the force, a colour that lasts less than 240 ms "
        "is drawn in the colour around it, so the lines stay readable; the percentage counts "
        "every moment."),))
    path = write_report_pdf(content, tmp_path / "report.pdf")
    pages = [" ".join(p.extract_text().split()) for p in PdfReader(path).pages]
    assert len(pages) == 3
    assert not any("(continued)" in page for page in pages)
    assert "Notes" in pages[1]
    assert "Visually guided reaching" in pages[2]


def test_a_robot_led_task_cut_short_says_how_much_of_its_timetable_ran(tmp_path):
    """Found trying the window: an isometric strength trial stopped at 9.6 s said
    "stopped early after 9.6 of 3 s", and its exercise "8 targets 5 cm from the centre;
    1 repetition of 3 s": `duration_s` is one push there, the trial 8 pushes with their
    rests (core.holdtasks), and the robot holds the hand still."""
    from core.assessment.protocol import protocol
    from tests.app.reports.made import cut

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Strength", side="right").code
    registry.open_session(code)
    parameters = protocol("strength").parameters(THESIS_SUBJECT)
    total_s = parameters.trajectory().total_duration_s
    assert total_s > 8 * parameters.duration_s
    trial_id = register(registry, code, parameters, session=1,
                        edit=lambda trial: cut(trial, 0.3, "stopped_early"))
    content = content_for_registry_trial(registry, trial_id)
    assert content.planned_s == total_s
    assert 0.0 < content.exercised_s < total_s
    header = {item.label: item.value for item in content.header}
    assert header["Ended"].endswith(f"of {total_s:.0f} s")
    assert header["Exercise"] == ("Isometric strength (assessment): 8 directions, a push "
                                  f"of {parameters.duration_s:g} s "
                                  f"each; 1 round, {total_s:.0f} s; the robot held the "
                                  "handle still")
    assert f"of {total_s:.0f} seconds" in content.status_text


def test_a_robot_led_task_s_help_line_says_what_the_robot_did(tmp_path):
    """Seen in the window: the strength trial's report said "Exercise: …; the robot held the
    handle still" and, under it, "Robot's help: 0 % (no help: the robot only makes itself
    lighter)", the transparent mode's words. The help line says what the robot did."""
    from core.assessment.protocol import protocol

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Strength", side="right").code
    registry.open_session(code)
    for task, did in (("strength", "the robot held the handle still"),
                      ("position", "the robot took the hand to each target and back")):
        trial_id = register(registry, code, protocol(task).parameters(THESIS_SUBJECT),
                            session=1)
        header = {item.label: item.value
                  for item in content_for_registry_trial(registry, trial_id).header}
        assert header["Robot's help"] == f"0 % ({did})", header["Robot's help"]
        assert header["Exercise"].endswith(did)
