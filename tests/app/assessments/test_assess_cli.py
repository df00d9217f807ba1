"""`rehab assess`: the tasks listed with their protocols, a task run for a registered patient
with its trials and figures in the registry as in the files, a patient's assessments shown,
and every bad input refused in one line (exit 2)."""

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.reader import read_trial
from core.assessment import TASKS, task_figures
from tests.app.cli.running import run


def test_the_tasks_are_listed_with_their_protocols(data, capsys):
    code, out, _ = run(["assess", "tasks"], capsys)
    assert code == 0
    for task in TASKS:
        assert out.count(f"\n{task}: ") + out.startswith(f"{task}: ") == 1, task
    assert out.count("  therapist: ") == len(TASKS)
    assert out.count("  patient: ") == len(TASKS)
    assert "2 trials (clockwise, counter-clockwise)" in out
    assert "Reaction time" in out or "reaction time" in out
    # every figure's key, the column a controls table (`rehab norms fit`) needs
    for task in TASKS:
        figures = next(line for line in out.split(f"\n{task}: ", 1)[-1].splitlines()
                       if line.startswith("  figures: "))
        for spec in task_figures(task):
            assert f"{spec.label} ({spec.unit}) {spec.key}" in figures, (task, spec.key)


def test_a_task_the_robot_leads_is_listed_as_the_window_says_it(data, capsys):
    """Clinic exploration 2 #4: strength and position sense were listed "1 × 3 s, robot
    transparent"; they say their timetable and what the robot does, in the words the
    Assessments tab and the Parameters tab use (app.assessments.words)."""
    from app.assessments.words import robot_task_words
    from core.assessment.protocol import protocol
    from core.trial import THESIS_SUBJECT

    _, out, _ = run(["assess", "tasks"], capsys)
    lines = {line.split(":")[0]: line for line in out.splitlines() if not line.startswith(" ")}
    for task in ("strength", "position"):
        words = robot_task_words(protocol(task).parameters(THESIS_SUBJECT))
        assert lines[task].endswith(f"1 trial: {words}"), lines[task]
        assert "transparent" not in lines[task]
    assert "1 round, 48 s; the robot holds the handle still" in lines["strength"]


def test_a_task_run_for_a_patient_is_registered_with_its_figures(data, patient, capsys):
    code, out, err = run(["assess", "run", patient, "--task", "reaching", "--patient", "weak",
                          "--seed", "2"], capsys)
    assert code == 0, err
    assert "Visually guided reaching — trial" in out
    registry = Registry(DataDir(data))
    (trial,) = registry.trials_for_patient(patient)
    assert trial.parameters["assessment"] == "reaching"
    assert trial.status == "complete"
    assert trial.patient_kind == "weak"
    stored = read_trial(registry.trial_path(trial), ()).metrics
    for spec in task_figures("reaching"):
        assert trial.metrics[spec.key] == pytest.approx(stored[spec.key], nan_ok=True)
    # the patient's body, not the default's, ran the task
    assert trial.parameters["body_mass_kg"] == 80.0
    code, out, _ = run(["assess", "show", patient], capsys)
    assert code == 0
    assert "Visually guided reaching — trial" in out
    assert "session 1, trial 1" in out
    code, out, _ = run(["assess", "show", patient, "--task", "circle"], capsys)
    assert "has no circle assessment yet" in out


def test_a_retest_the_same_day_goes_into_a_new_session(data, patient, capsys):
    """A test-retest pair (`rehab norms mdc`) recorded the same day: every run went into
    today's session, so the retest could not be session 2 from the command line."""
    for extra in ([], ["--new-session"]):
        code, _, err = run(["assess", "run", patient, "--task", "strength", *extra], capsys)
        assert code == 0, err
    code, _, err = run(["run", "--code", patient, "--repetitions", "1", "--duration", "3",
                        "--seed", "1", "--new-session"], capsys)
    assert code == 0, err
    code, _, err = run(["run", "--code", patient, "--repetitions", "1", "--duration", "3",
                        "--seed", "1"], capsys)
    assert code == 0, err
    registry = Registry(DataDir(data))
    numbers = [(t.session_number, t.number) for t in registry.trials_for_patient(patient)]
    assert numbers == [(1, 1), (2, 1), (3, 1), (3, 2)]
    code, _, err = run(["run", "--new-session", "--repetitions", "1"], capsys)
    assert code == 2
    assert "--new-session needs --code" in err


@pytest.mark.parametrize(("args", "needle"), [
    (["assess", "run", "NOPE", "--task", "reaching"], "NOPE"),
    (["assess", "run", "{code}", "--task", "walking"], "invalid choice"),
    (["assess", "run", "{code}", "--task", "reaching", "--seed", "-1"], "--seed -1"),
    (["assess", "run", "{code}"], "--task"),
    (["assess", "show", "NOPE"], "NOPE"),
])
def test_a_bad_request_is_one_line(data, patient, capsys, args, needle):
    code, _out, err = run([a.replace("{code}", patient) for a in args], capsys)
    assert code == 2
    assert needle in err
    assert len(err.strip().splitlines()) == 1, err
    registry = Registry(DataDir(data))
    assert registry.trials_for_patient(patient) == []


def test_a_patient_who_cannot_reach_round_the_default_centre_is_told_of_centre(data, capsys):
    """A shorter arm (0.29 + 0.27 m) cannot reach the targets round the table's default
    centre: the refusal said "move the exercise", which `assess run` had no way to do."""
    code, out, err = run(["patients", "add", "--first-name", "Dee", "--body-mass", "65",
                          "--upper-arm", "0.29", "--forearm", "0.27", "--side", "right",
                          "--shoulder", "-0.12", "0.73"], capsys)
    assert code == 0, err
    patient = out.strip()
    code, _, err = run(["assess", "run", patient, "--task", "reaching"], capsys)
    assert code == 2
    assert len(err.strip().splitlines()) == 1, err
    assert "move the tasks with --centre X Y, now -0.3 0.3 m" in err
    code, _, err = run(["assess", "run", patient, "--task", "reaching", "--centre", "-0.25",
                        "0.38"], capsys)
    assert code == 0, err
    (trial,) = Registry(DataDir(data)).trials_for_patient(patient)
    assert trial.status == "complete"
    assert trial.parameters["centre_m"] == [-0.25, 0.38]
