"""The post-trial report: its content, its words, its comparisons, and the PDF itself."""

from __future__ import annotations

import dataclasses
import datetime
import itertools
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from pypdf import PdfReader

from app.errors import AppError, TrialFileError
from app.records.registry import Registry
from app.reports.build import (
    Baseline,
    build_report,
    merge_short_runs,
    report_for_registry_trial,
    write_report_pdf,
)
from app.reports.compare import metric_text, patient_changes, table_rows
from app.reports.metrics_table import ROW_BY_KEY, format_metrics
from app.reports.plain_language import force_text, mass_text, parameter_cautions, plain_lines
from app.reports.task_table import task_order
from app.trials.assistance_timeline import AssistanceInEffect
from app.trials.headless import save, simulate
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PHASE_EXERCISE
from device.recording.trialfile import SubjectInfo, write_trial
from device.safety.faults import Fault

SHORT = THESIS_SUBJECT.replace(repetitions=1)
T0 = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=datetime.UTC)
FIRST, LAST = "Zenobia", "Quillfeather"


def pdf_text(path: Path) -> str:
    return "\n".join(page.extract_text() for page in PdfReader(path).pages)


def stopped(trial, n_samples: int, status: str):
    """The simulated trial cut after n_samples, ended by a fault or by the therapist."""
    tick = n_samples
    if status == "faulted":
        last = {"time_s": tick * 0.002, "tick": tick, "kind": "fault",
                "message": Fault.FORCE_LIMIT.banner({"force_N": 63.2, "limit_N": 50.0}),
                "values": {"fault": "force_limit", "code": int(Fault.FORCE_LIMIT)}}
    else:
        last = {"time_s": tick * 0.002, "tick": tick, "kind": "stop",
                "message": "stopped by the therapist", "values": {}}
    events = (*[e for e in trial.events if e["kind"] == "start"], last)
    return dataclasses.replace(trial, records=trial.records[:n_samples], events=events,
                               status=status)


@pytest.fixture(scope="module")
def healthy_file(tmp_path_factory) -> Path:
    path = tmp_path_factory.mktemp("healthy") / "healthy.h5"
    save(simulate(SHORT, patient="healthy"), path)
    return path


@pytest.fixture(scope="module")
def healthy_pdf(healthy_file, tmp_path_factory) -> Path:
    content = build_report(read_trial(healthy_file))
    return write_report_pdf(content, tmp_path_factory.mktemp("pdf") / "report.pdf")


def test_the_note_on_how_the_colours_are_drawn_is_a_plain_sentence(healthy_file):
    """Trying a session: the therapist's page read "the path and Fig. 3.9 draw runs
    shorter than 51 ms in the colour around them": a lowercase fragment in jargon."""
    content = build_report(read_trial(healthy_file))
    (note,) = [n for n in content.notes if "percentage counts" in n]
    assert note.startswith("In the drawings of the path and of the force, a colour that "
                           "lasts less than ")
    assert note.endswith("percentage counts every moment.")
    assert "Fig." not in note
    assert "runs" not in note


# -- the PDF -------------------------------------------------------------------------------

def test_the_pdf_has_two_pages_and_the_thesis_figures_computed_from_the_file(
        healthy_file, healthy_pdf):
    reader = PdfReader(healthy_pdf)
    assert len(reader.pages) == 2
    text = pdf_text(healthy_pdf)

    # Independently of the report's code: the exercise samples of the file.
    trial = read_trial(healthy_file)
    ex = trial.channels["phase"] == PHASE_EXERCISE
    t = trial.channels["time"][ex]
    error = trial.channels["position"][ex] - trial.channels["position_desired"][ex]
    rmse_mm = np.sqrt(np.mean(error ** 2, axis=0)) * 1000.0
    force = trial.channels["force"][ex]
    direction = trial.channels["direction_desired"][ex]
    cross = force[:, 0] * direction[:, 1] - force[:, 1] * direction[:, 0]
    angle = np.arctan2(np.abs(cross), np.sum(force * direction, axis=1))
    within = (angle <= SHORT.tolerance_rad) & (np.hypot(*force.T) >= 0.25)
    percent = 100.0 * np.sum(np.diff(t)[within[:-1]]) / (t[-1] - t[0])
    isb = np.degrees(trial.channels["subject_angle_isb"][ex])
    rom = isb.max(axis=0) - isb.min(axis=0)
    torque = trial.channels["subject_torque"][ex]
    torque_range = torque.max(axis=0) - torque.min(axis=0)

    assert f"Position error, x (RMSE) (mm) {rmse_mm[0]:.1f}" in text
    assert f"Position error, y (RMSE) (mm) {rmse_mm[1]:.1f}" in text
    assert f"{percent:.0f} %" in text
    assert f"You pushed in the right direction {round(percent)} % of the time" in text
    assert f"range {np.ptp(force[:, 0]):.2f} N" in text
    assert f"range {np.ptp(force[:, 1]):.2f} N" in text
    assert f"range of motion {rom[0]:.1f}°" in text
    assert f"range of motion {rom[1]:.1f}°" in text
    assert f"range {torque_range[0]:.2f} N·m raw" in text
    assert f"Your shoulder moved through {round(rom[0])}°" in text
    # the therapist's page names the thesis's figures; the patient's page is plain words
    therapist = reader.pages[1].extract_text()
    for figure in ("Fig. 3.9", "Fig. 3.11", "Fig. 3.12"):
        assert figure in therapist
    patient = reader.pages[0].extract_text()
    for jargon in ("Fig.", "close other programs", " ms ", "runs shorter"):
        assert jargon not in patient, jargon
    assert "Simulated trial" in text


def test_the_pdf_text_is_embedded_truetype(healthy_pdf):
    fonts = set()
    for page in PdfReader(healthy_pdf).pages:
        for font in page["/Resources"]["/Font"].values():
            font = font.get_object()
            fonts.add((str(font["/Subtype"]), str(font["/BaseFont"]).split("+")[-1]))
    assert fonts
    # Type 42 is written as a CID-keyed TrueType font (Type0 over CIDFontType2).
    assert all(subtype == "/Type0" and name.startswith("DejaVuSans")
               for subtype, name in fonts)


# -- the patient's words ---------------------------------------------------------------------

def test_plain_lines_say_the_numbers_in_plain_words():
    lines = {line.key: line for line in plain_lines({
        "directional_performance_pct": 78.0, "tolerance_rad": math.radians(20.0),
        "rmse_x_m": 0.00868, "rmse_y_m": 0.00702,
        "shoulder_rom_rad": math.radians(42.17), "elbow_rom_rad": math.radians(30.65),
    }, peak_force_N=6.0)}
    assert lines["directional_performance_pct"].text == (
        "You pushed in the right direction 78 % of the time.")
    assert "20°" in lines["directional_performance_pct"].detail
    # √(8.68² + 7.02²) = 11.16 mm from the moving target, the robot's doing (issue 27 #8)
    assert lines["rmse"].text == "The robot kept your hand on average 11 mm from the moving ring."
    assert lines["shoulder_rom_rad"].text == "Your shoulder moved through 42°."
    assert lines["elbow_rom_rad"].text == "Your elbow moved through 31°."
    assert "600 g" in lines["peak_force_N"].detail
    for line in lines.values():
        for jargon in ("RMSE", "ROM", "ISB", "rad"):
            assert jargon not in line.text.split()


def test_plain_lines_leave_out_missing_figures_and_never_say_zero_mm():
    lines = plain_lines({"directional_performance_pct": math.nan, "tolerance_rad": 0.35,
                         "rmse_x_m": 0.0002, "rmse_y_m": 0.0001})
    assert [line.key for line in lines] == ["rmse"]
    assert "on average 1 mm" in lines[0].text
    assert mass_text(20.0) == "2.0 kg"
    assert mass_text(0.4) == "50 g"
    # a passive hand's 0.21 N (21 g) is no 50 g, and no "0 N"
    assert mass_text(0.21) == "less than 50 g"
    force = plain_lines({"tolerance_rad": 0.35}, peak_force_N=0.21)
    assert [(line.text, line.detail) for line in force] == [
        ("Your firmest push on the handle was 0.2 N.",
         "About the effort of holding up less than 50 g.")]
    assert force_text(12.4) == "12"


# -- change since an earlier trial ----------------------------------------------------------

def _metrics(pct, rmse_mm, shoulder_deg=40.0):
    return {"directional_performance_pct": pct, "rmse_x_m": rmse_mm / 1000.0, "rmse_y_m": 0.0,
            "shoulder_rom_rad": math.radians(shoulder_deg), "elbow_rom_rad": math.nan}


@pytest.mark.parametrize(("before", "after", "direction"), [
    (_metrics(60.0, 9.0), _metrics(78.0, 5.0), "better"),
    (_metrics(78.0, 5.0), _metrics(60.0, 9.0), "worse"),
    (_metrics(78.2, 5.2), _metrics(77.9, 4.9), "same"),
])
def test_better_and_worse_follow_each_figure_s_direction(before, after, direction):
    changes = {c.key: c for c in patient_changes(before, after)}
    assert changes["directional_performance_pct"].verdict == direction
    assert "rmse" not in changes  # the robot's doing: not the patient's change
    assert "elbow_rom_rad" not in changes  # NaN on both sides: no line
    text = changes["directional_performance_pct"].text
    assert text.startswith("Pushed in the right direction: ")
    assert text.endswith({"better": "better", "worse": "worse", "same": "the same"}[direction])


def test_ranges_of_motion_are_more_or_less_never_better_or_worse():
    changes = {c.key: c for c in patient_changes(_metrics(70, 5, 30.0), _metrics(70, 5, 45.0))}
    assert changes["shoulder_rom_rad"].verdict == "more"
    assert changes["shoulder_rom_rad"].arrow == "↑"
    assert changes["shoulder_rom_rad"].text == "Shoulder movement: 30° → 45°, more"


def test_the_therapist_table_compares_each_figure_with_its_goal():
    now = {"rmse_x_m": 0.004, "directional_performance_pct": 70.0, "path_length_ratio": 1.02,
           "force_range_x_N": 3.0}
    earlier = Baseline({"rmse_x_m": 0.006, "directional_performance_pct": 80.0,
                        "path_length_ratio": 0.95, "force_range_x_N": 3.0})
    rows = {row.key: row for row in table_rows(now, (earlier,))}
    assert rows["rmse_x_m"].value_text == "4.0"
    assert rows["rmse_x_m"].earlier_texts == ("was 6.0: now ↓ better",)
    assert rows["directional_performance_pct"].verdicts == ("worse",)
    assert rows["path_length_ratio"].verdicts == ("better",)  # 1.02 is nearer 1 than 0.95
    assert rows["force_range_x_N"].verdicts == ("same",)
    assert "sparc" not in rows  # not in this trial: no row


def test_a_change_within_the_shown_precision_or_the_mdc_is_about_the_same():
    """Trying a session: the table said "LDLJ −16.27, was −16.25: now ↓ worse" and called
    a circle ratio of 0.91 after 0.92 worse. A change of one shown step, or within the
    figure's MDC95 where the norms give one, is "about the same"; beyond it, a verdict."""
    order = task_order("circle", "transparent")
    before = {"circle_ratio": 0.92, "circle_ldlj": -16.25, "circle_sparc": -1.50}
    after = {"circle_ratio": 0.91, "circle_ldlj": -16.27, "circle_sparc": -1.60}
    rows = {row.key: row for row in table_rows(after, (Baseline(before),), order=order,
                                               least_change={"circle_ldlj": 0.12})}
    assert rows["circle_ratio"].earlier_texts == ("was 0.92: now ≈ about the same",)
    assert rows["circle_ldlj"].verdicts == ("about the same",)  # within its MDC95
    assert rows["circle_sparc"].verdicts == ("worse",)  # 0.10: ten steps, no MDC given
    # a change beyond the MDC is one
    rows = {row.key: row for row in table_rows(
        {"circle_ldlj": -16.50}, (Baseline(before),), order=order,
        least_change={"circle_ldlj": 0.12})}
    assert rows["circle_ldlj"].verdicts == ("worse",)


def test_the_table_never_says_worse_where_the_patients_page_says_the_same():
    """78.2 % → 78.4 %: the patient reads 78 % twice, "the same"; the table says "same"
    too (it compares at the patient's whole mm, %, degrees), and its cell reads as the
    change to this trial."""
    before = {"rmse_x_m": 0.00102, "rmse_y_m": 0.00102, "directional_performance_pct": 78.2}
    after = {"rmse_x_m": 0.00106, "rmse_y_m": 0.00106, "directional_performance_pct": 78.4}
    patient = {c.key: c.verdict for c in patient_changes(before, after)}
    rows = {row.key: row for row in table_rows(after, (Baseline(before),))}
    assert patient["directional_performance_pct"] == "same"
    assert rows["directional_performance_pct"].verdicts == ("same",)
    assert rows["rmse_x_m"].earlier_texts == ("was 1.0: now = same",)


def test_the_therapist_table_writes_each_figure_as_the_tabs_and_the_patient_do():
    """The therapist's table read "Mean speed 130.36 mm/s", "Led the movement 99.05 %",
    "Shoulder range of motion 46.22°" and "0.86 mm" where the Trajectory tab said 0.9 mm,
    the Force tab 31 %, the Joint angles tab 45.8° and the patient's page 99 %: each figure
    is written in its unit's decimals, as the tabs write it (and the terminal's table)."""
    metrics = {"rmse_x_m": 0.00086, "led_pct": 99.05, "directional_performance_pct": 30.68,
               "shoulder_rom_rad": math.radians(46.22), "mean_speed_m_s": 0.13036,
               "force_range_x_N": 11.24, "robot_work_share": 0.0, "movement_time_s": 20.3}
    rows = {row.key: row.value_text for row in table_rows(metrics, (), mode="as-needed")}
    assert rows == {"rmse_x_m": "0.9", "led_pct": "99", "directional_performance_pct": "31",
                    "shoulder_rom_rad": "46.2", "mean_speed_m_s": "130",
                    "force_range_x_N": "11.24", "robot_work_share": "0",
                    "movement_time_s": "20.30"}
    assert metric_text(ROW_BY_KEY["mean_speed_m_s"], 0.21079) == "211 mm/s"
    terminal = format_metrics(metrics)
    assert "130 mm/s" in terminal
    assert "99.05" not in terminal


def test_a_changed_exercise_comes_with_a_caution():
    base = THESIS_SUBJECT.to_dict()
    bigger_faster = THESIS_SUBJECT.replace(radius_m=0.12, duration_s=3.0).to_dict()
    cautions = parameter_cautions(base, bigger_faster)
    assert any("larger D" in c and "a higher error is expected" in c for c in cautions)
    assert any("faster" in c and "3 s per lap" in c for c in cautions)
    assert parameter_cautions(base, base) == ()
    wider = THESIS_SUBJECT.replace(tolerance_rad=math.radians(30.0)).to_dict()
    assert "higher direction score is expected" in parameter_cautions(base, wider)[0]
    circle = THESIS_SUBJECT.replace(shape="circle", radius_m=0.05).to_dict()
    (only,) = parameter_cautions(base, circle)
    assert "different exercise" in only
    # the circle task's second trial against its first: the other way round
    ccw = THESIS_SUBJECT.replace(shape="circle", clockwise=False).to_dict()
    cw = THESIS_SUBJECT.replace(shape="circle", clockwise=True).to_dict()
    (only,) = parameter_cautions(cw, ccw)
    assert only == ("This trial went round the circle the other way (counter-clockwise; before, "
                    "clockwise), so the figures do not compare directly.")


def test_the_report_compares_with_earlier_trials_and_cautions_in_the_pdf(
        healthy_file, tmp_path):
    trial = read_trial(healthy_file)
    earlier = THESIS_SUBJECT.replace(radius_m=0.08, duration_s=6.0)
    worse = {**trial.metrics, "rmse_x_m": trial.metrics["rmse_x_m"] * 3,
             "directional_performance_pct": trial.metrics["directional_performance_pct"] - 30}
    full = AssistanceInEffect(((0.0, 1.0),))
    content = build_report(
        trial,
        previous_trial=Baseline(worse, earlier.to_dict(), 2, 4, levels=full),
        previous_session=Baseline(dict(trial.metrics), SHORT.to_dict(), 1, 7, levels=full),
    )
    last, session = content.comparisons
    # another size and pace: the numbers side by side, no verdict (issue 27 #8)
    assert {c.verdict for c in last.changes} == {""}
    assert any("larger D" in c for c in last.cautions)
    assert any("faster (4 s per lap; before, 6 s)" in c for c in last.cautions)
    assert session.cautions == ()  # same exercise, same help
    assert {c.verdict for c in session.changes} == {"same"}
    text = pdf_text(write_report_pdf(content, tmp_path / "r.pdf"))
    assert "Since last time" in text
    assert "session 2, trial 4" in text
    assert "Not compared with the last trial: this trial used a larger D" in text
    assert "not compared" in text


# -- Fig. 3.9's runs -------------------------------------------------------------------------

def test_short_runs_are_merged_and_the_runs_tile_the_exercise():
    t = np.arange(5000) * 0.002  # 10 s
    rng = np.random.default_rng(1)
    within = (np.sin(t) > 0) ^ (rng.random(t.size) < 0.05)  # 5 % of samples flipped
    raw_runs = np.count_nonzero(within[1:] != within[:-1]) + 1
    runs = merge_short_runs(t, within, 0.05)
    assert raw_runs > 300
    assert len(runs) < 10
    assert runs[0].start == 0
    assert runs[-1].stop == t.size - 1
    for a, b in itertools.pairwise(runs):
        assert b.start == a.stop
        assert a.within != b.within
        assert t[a.stop] - t[a.start] >= 0.05
    # The long stretches keep their state: sin(t) > 0 on (0, π).
    assert runs[0].within
    assert t[runs[0].stop] == pytest.approx(math.pi, abs=0.1)


def test_runs_already_long_enough_are_kept_as_they_are():
    t = np.arange(100) * 0.01
    within = np.r_[np.ones(40, bool), np.zeros(60, bool)]
    runs = merge_short_runs(t, within, 0.05)
    assert [(r.within, r.start, r.stop) for r in runs] == [(True, 0, 40), (False, 40, 99)]


# -- names -----------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def registry_trials(tmp_path_factory):
    """A patient with a name, a complete trial in session 1 and two in session 2."""
    registry = Registry(tmp_path_factory.mktemp("registry") / "data")
    patient = registry.create_patient(FIRST, LAST)
    ids = []
    for session, minutes, params, kind in ((1, 0, SHORT, "weak"),
                                           (2, 7 * 24 * 60, SHORT, "wrong_way"),
                                           (2, 7 * 24 * 60 + 10, SHORT.replace(radius_m=0.12),
                                            "healthy")):
        started = T0 + datetime.timedelta(minutes=minutes)
        begun = registry.begin_trial(patient.code, params, backend="simulator",
                                     session_number=session, started_at=started)
        analysis = save(simulate(params, patient=kind), begun.path, subject_code=patient.code)
        registry.finish_trial(begun.trial_id, "complete", analysis.metrics.to_dict(),
                              ended_at=started + datetime.timedelta(minutes=1))
        ids.append(begun.trial_id)
    return registry, patient, ids


def test_a_registered_trial_s_report_goes_where_the_data_folder_says_without_names(
        registry_trials):
    registry, patient, ids = registry_trials
    path = report_for_registry_trial(registry, ids[-1])
    record = registry.trial(ids[-1])
    assert path == registry.data_dir.report_path(patient.code, 2, 2, record.started_at)
    text = pdf_text(path)
    assert patient.code in text
    assert "session 2, trial 2" in text
    assert "session 2, trial 1" in text  # the previous trial
    assert "session 1, trial 1" in text  # the previous session
    assert "larger D" in text
    metadata = " ".join(str(v) for v in PdfReader(path).metadata.values())
    for name in (FIRST, LAST):
        assert name.lower() not in text.lower()
        assert name.lower() not in metadata.lower()
        assert name.encode() not in path.read_bytes()


def test_a_report_saved_under_a_name_the_data_folder_keeps_replaces_nothing(registry_trials):
    """The window's "Save the report" dialog confirms a name that exists, so the PDF may
    replace a file; but never a trial file or anything else the data folder keeps (issue
    28 #1: a report saved as the trial's own .h5 replaced the trial)."""
    from app.reports.build import content_for_registry_trial

    registry, _, ids = registry_trials
    content = content_for_registry_trial(registry, ids[0])
    trial = registry.trial_path(registry.trial(ids[0]))
    kept = {path: path.read_bytes() for path in (trial, registry.path)}
    for name in (trial, registry.path, trial.with_suffix(".pdf"),
                 registry.data_dir.root / "report.pdf"):
        with pytest.raises(AppError, match="cannot write the report"):
            write_report_pdf(content, name)
    assert {path: path.read_bytes() for path in kept} == kept
    assert not trial.with_suffix(".pdf").exists()


def test_the_first_name_appears_only_when_asked_for_and_never_the_last(registry_trials, tmp_path):
    registry, _, ids = registry_trials
    text = pdf_text(report_for_registry_trial(registry, ids[0], tmp_path / "named.pdf",
                                              include_first_name=True))
    assert FIRST in text
    assert LAST.lower() not in text.lower()


# -- trials that did not end well, and files that cannot be read ------------------------------

@pytest.mark.parametrize(("status", "words"), [
    ("faulted", "The robot stopped the exercise for safety after 2 of 4 seconds"),
    ("stopped_early", "The exercise was stopped early, after 2 of 4 seconds"),
])
def test_a_trial_that_ended_early_says_so(tmp_path, status, words):
    path = tmp_path / "cut.h5"
    save(stopped(simulate(SHORT), 1000, status), path)
    content = build_report(read_trial(path))
    assert content.status == status
    text = pdf_text(write_report_pdf(content, tmp_path / "cut.pdf"))
    assert words in text.replace("\n", " ")
    if status == "faulted":
        assert "Force on the handle reached 63 N (limit 50 N)" in text
    else:
        assert "Force on the handle reached" not in text


def test_a_trial_that_ended_before_the_exercise_still_has_a_report(tmp_path):
    path = tmp_path / "early.h5"
    trial = stopped(simulate(SHORT), 30, "faulted")  # 60 ms: too short for any figure
    write_trial(path, trial.records, parameters=SHORT,
                subject=SubjectInfo.from_parameters("SIM", SHORT), robot=trial.plan.robot,
                backend="simulator (healthy, seed 0)", sample_period_s=trial.plan.period_s,
                events=trial.events, status=trial.status)
    content = build_report(read_trial(path))
    assert content.metrics is None
    assert any(note.startswith("the trial has only ") and note.endswith(
        "are needed for its figures") for note in content.notes)  # app.trials.analysis's
    assert content.path is None
    assert content.plain == ()
    text = pdf_text(write_report_pdf(content, tmp_path / "early.pdf"))
    assert "No exercise was recorded" in text
    assert len(PdfReader(tmp_path / "early.pdf").pages) == 2


@pytest.fixture
def registered(tmp_path, healthy_file):
    """A registry holding one complete trial, its file a copy of the healthy one."""
    registry = Registry(tmp_path / "data")
    patient = registry.create_patient(FIRST, LAST)
    begun = registry.begin_trial(patient.code, SHORT, backend="simulator", started_at=T0)
    shutil.copyfile(healthy_file, begun.path)
    registry.finish_trial(begun.trial_id, "complete", read_trial(begun.path).metrics,
                          ended_at=T0 + datetime.timedelta(minutes=1))
    return registry, begun.trial_id


def test_a_missing_trial_file_is_an_error_naming_it(registered):
    registry, trial_id = registered
    registry.trial_path(trial_id).unlink()
    with pytest.raises(TrialFileError, match="does not exist") as error:
        report_for_registry_trial(registry, trial_id)
    assert str(registry.trial_path(trial_id)) in str(error.value)


def test_a_damaged_trial_file_is_an_error_naming_it(registered):
    registry, trial_id = registered
    path = registry.trial_path(trial_id)
    path.write_bytes(b"not a trial file at all" * 100)
    with pytest.raises(TrialFileError, match="not an HDF5 file") as error:
        report_for_registry_trial(registry, trial_id)
    assert str(path) in str(error.value)
    assert not list(registry.data_dir.reports_dir.rglob("*.pdf"))


def test_a_report_into_a_missing_folder_is_refused_and_leaves_nothing(healthy_file, tmp_path):
    content = build_report(read_trial(healthy_file))
    with pytest.raises(AppError, match="does not exist"):
        write_report_pdf(content, tmp_path / "nowhere" / "r.pdf")
    path = write_report_pdf(content, tmp_path / "r.pdf")
    assert "Seen from your seat" in pdf_text(path)
    assert [p.name for p in tmp_path.iterdir()] == ["r.pdf"]  # no temporary file left


def test_an_as_needed_trial_gets_a_page_of_the_help_the_robot_learned(tmp_path):
    """Issue 12 #8: the learned feedforward per repetition, in the report a researcher and
    a therapist get: a third page with one line per repetition and the figures in words."""
    params = THESIS_SUBJECT.replace(repetitions=3, assist="as-needed")
    path = tmp_path / "passive.h5"
    save(simulate(params, patient="passive"), path)
    data = read_trial(path)
    history = data.assistance["feedforward_N"]
    assert history.shape[0] == 3
    assert data.assistance["mode"] == "as-needed"
    content = build_report(data)
    figure = content.feedforward
    np.testing.assert_array_equal(figure.force_N, history)
    assert figure.percent_of_repetition[0] > 0
    assert figure.percent_of_repetition[-1] < 100
    pdf = write_report_pdf(content, tmp_path / "passive.pdf")
    assert len(PdfReader(pdf).pages) == 3
    text = PdfReader(pdf).pages[2].extract_text()
    assert "The help the robot learned along the path" in text
    assert f"Repetition 1: up to {history[0].max():.1f} N" in text
    assert f"repetition 3: up to {history[2].max():.1f} N" in text
    # the thesis mode learns nothing: no such page
    assert build_report(read_trial(write_trial_thesis(tmp_path))).feedforward is None


def test_the_help_learned_in_a_single_repetition_is_said_once(tmp_path):
    """Trying the window: a game round of one lap said "Repetition 1: up to 1.0 N;
    repetition 1: up to 1.0 N"."""
    params = THESIS_SUBJECT.replace(repetitions=1, assist="as-needed")
    path = tmp_path / "passive.h5"
    save(simulate(params, patient="passive"), path)
    content = build_report(read_trial(path))
    assert content.feedforward.force_N.shape[0] == 1
    pdf = write_report_pdf(content, tmp_path / "passive.pdf")
    text = " ".join(PdfReader(pdf).pages[-1].extract_text().split())
    learned = content.feedforward.force_N[0].max()
    assert f"One repetition: up to {learned:.1f} N (limit 3 N;" in text
    assert "repetition 1: up to" not in text


def test_help_learned_nowhere_is_said_in_words_not_drawn_as_an_empty_chart(tmp_path):
    """Trying the window: a healthy patient's as-needed trial learned 0.0 N everywhere and
    its page was a chart whose every line lay hidden on its floor. It says so in words."""
    from app.reports.pdf import report_pages

    params = THESIS_SUBJECT.replace(repetitions=2, assist="as-needed")
    path = tmp_path / "healthy.h5"
    save(simulate(params, patient="healthy", seed=3), path)
    content = build_report(read_trial(path))
    assert content.feedforward.force_N.max() < 0.05  # learned none
    help_page = report_pages(content)[-1]
    assert help_page.axes == []  # no chart
    pdf = write_report_pdf(content, tmp_path / "healthy.pdf")
    text = " ".join(PdfReader(pdf).pages[-1].extract_text().split())
    assert "The help the robot learned along the path" in text
    assert "None: under 0.05 N at every point of all 2 repetitions" in text
    assert "Repetition 1: up to" not in text


def write_trial_thesis(folder: Path) -> Path:
    path = folder / "thesis.h5"
    save(simulate(SHORT, patient="passive"), path)
    return path


def test_the_report_says_why_a_trial_ended_when_its_file_cannot(tmp_path):
    """Issue 13 #18: a trial whose recorder died has no fault event in its file; the
    registry keeps the words and the report shows them."""
    from app.records.datadir import DataDir
    from app.reports.build import content_for_registry_trial
    from app.trials.finalize import finalize_lost

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Lovelace", body_mass_kg=91.0).code
    begun = registry.begin_trial(code, SHORT, backend="simulator")
    save(stopped(simulate(SHORT, patient="healthy"), 1500, "stopped_early"), begun.path,
         subject_code=code)
    finalize_lost(registry, begun.trial_id, "the recorder process stopped: restart")
    content = content_for_registry_trial(registry, begun.trial_id)
    assert "the recorder process stopped: restart" in content.faults
    assert ("Fault", "the recorder process stopped: restart") in [
        (item.label, item.value) for item in content.therapist_header]


def test_the_settings_line_names_the_controller_and_a_learned_model(healthy_file):
    """The report's Settings line says which controller ran, as the Parameters tab names
    it: a learned model by its name (issue 15), positions in cm."""
    from app.reports.content import _settings_text

    header = {item.label: item.value
              for item in build_report(read_trial(healthy_file)).therapist_header}
    assert header["Settings"].startswith("SMC controller, thesis-mode assistance at 100 % "
                                         "(built at 100 %)")
    assert "centre (-30.0, 30.0) cm" in header["Settings"]
    learned = SHORT.replace(controller="ctpid", learned_model="fnn-robot")
    full = AssistanceInEffect(((0.0, 1.0),))
    assert _settings_text(learned, full).startswith("CT-PID (learned: fnn-robot) controller")
    assert _settings_text(SHORT.replace(controller="ctpid"), full).startswith(
        "CT-PID controller")


def test_a_transparent_trial_s_motors_are_not_said_to_have_moved_the_handle(tmp_path):
    """The transparent robot's torque is a function of its own state alone (its friction,
    inertia, stiffness: core.control.transparent): its motors' work goes into the robot.
    Page 1 said "You did 49 % of the work of moving the handle; the robot did 51 %" under
    "Robot's help 0 % (no help)" for the reaching task (issue of hN's screenshots). The
    figures stay in the record; the words say who moved the handle."""
    from app.reports.plain_language import robot_only_lightened

    path = tmp_path / "transparent.h5"
    save(simulate(SHORT.replace(assist="transparent"), patient="healthy"), path)
    data = read_trial(path)
    assert data.metrics["robot_work_J"] > 0.0  # the motors did work: on the robot itself
    # the share counts only the help (core.work.MechanicalWork): the transparent robot's is none
    assert data.metrics["robot_work_share"] <= 0.01
    content = build_report(data)
    lines = {line.key: line for line in content.plain}
    assert lines["robot_work_share"].text == "You did all of the work of moving the handle."
    # the therapist's table keeps the net works measured, not a share of moving the handle
    table = [row.key for row in content.table]
    assert "robot_work_J" in table
    assert "patient_work_J" in table
    assert "robot_work_share" not in table
    assert "the robot did" not in " ".join(line.text for line in lines.values())
    # a task the patient leads runs the same law all through; one the robot leads does not
    assert robot_only_lightened(SHORT.replace(assist="transparent", assessment="reaching"))
    assert not robot_only_lightened(SHORT.replace(assist="transparent", assessment="position"))
    assert not robot_only_lightened(SHORT.replace(assist="as-needed"))
    # the other modes still say the shares
    share = plain_lines({"robot_work_share": 0.51, "patient_work_J": 1.0})
    assert share[0].text.endswith("the robot did 51 %.")
