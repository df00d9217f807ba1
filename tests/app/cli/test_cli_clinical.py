"""`rehab scales`, `note`, `notes`, `invalid`, `valid`, `correct`, `corrections` (schema
v8, issue 31): the therapist's records on the command line; every bad input one line,
exit 2, nothing stored."""

import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import THESIS_SUBJECT
from tests.app.cli.running import run


@pytest.fixture
def patient(data, capsys):
    code, out, _ = run(["patients", "add", "--first-name", "Ada", "--last-name", "Example",
                        "--upper-arm", "0.30", "--sex", "female", "--handedness", "right"],
                       capsys)
    assert code == 0
    code_text = out.strip()
    registry = Registry(DataDir(data))
    for _ in range(2):
        begun = registry.begin_trial(code_text, THESIS_SUBJECT, backend="simulator",
                                     session_number=1)
        registry.finish_trial(begun.trial_id, "complete", {"rmse_x_m": 0.01})
    return code_text


def registry_of(data):
    return Registry(DataDir(data))


def test_a_therapist_records_scales_notes_marks_and_corrections(data, patient, capsys):
    registry = registry_of(data)
    assert (registry.patient(patient).sex, registry.patient(patient).handedness) == (
        "female", "right")

    code, out, _ = run(["scales", "add", patient, "1", "fugl_meyer", "A=20", "B=5", "C=6",
                        "D=3", "--by", "K. Lee"], capsys)
    assert code == 0
    assert "Fugl-Meyer UE motor 34/66 (A 20, B 5, C 6, D 3)" in out
    assert run(["scales", "add", patient, "1", "pain", "4", "--by", "K. Lee"], capsys)[0] == 0
    assert run(["scales", "add", patient, "1", "ashworth", "elbow_flexors=1+",
                "wrist_flexors=2", "--by", "K. Lee"], capsys)[0] == 0
    code, out, _ = run(["scales", "show", patient], capsys)
    assert code == 0
    assert "session 1:" in out
    assert "Pain (NRS) 4/10" in out
    assert "elbow flexors 1+" in out
    scales = registry.session_scales(patient)[1]
    assert (scales["fugl_meyer"].total, scales["fugl_meyer"].rater) == (34, "K. Lee")

    first, second = (t.id for t in registry.trials_for_patient(patient))
    code, out, _ = run(["note", patient, "1", "let go at 12 s", "--trial", str(second),
                        "--by", "K. Lee"], capsys)
    assert code == 0
    run(["note", patient, "1", "tired today", "--by", "K. Lee"], capsys)
    code, out, _ = run(["notes", patient], capsys)
    assert "let go at 12 s" in out
    assert "tired today" in out

    code, out, _ = run(["invalid", str(second), "--reason", "let go of the handle", "--by",
                        "K. Lee"], capsys)
    assert code == 0
    assert "marked invalid" in out
    assert [t.id for t in registry.trial_summaries(patient)] == [first]
    code, out, _ = run(["trials", patient], capsys)
    assert "INVALID: let go of the handle" in out
    assert "note: let go at 12 s" in out
    code, out, _ = run(["valid", str(second), "--reason", "fine on replay", "--by", "M. Roy"],
                       capsys)
    assert code == 0
    assert [t.id for t in registry.trial_summaries(patient)] == [first, second]

    code, out, _ = run(["correct", patient, "upper_arm_m", "0.31", "--reason",
                        "measured again", "--by", "K. Lee"], capsys)
    assert code == 0
    assert "0.3 → 0.31" in out
    # a value starting with '-' comes after '--', as for any command
    assert run(["correct", patient, "shoulder_m", "--reason", "chair moved", "--by",
                "K. Lee", "--", "-0.12,0.73"], capsys)[0] == 0
    assert registry.patient(patient).shoulder_m == (-0.12, 0.73)
    code, out, _ = run(["corrections", patient], capsys)
    assert "upper_arm_m: 0.3 → 0.31  (measured again)" in out


def test_scales_taken_before_the_first_trial_open_the_session(data, capsys):
    """`rehab scales add` at the start of a session, before any trial: it was refused ("a
    session begins with its first trial"); the patient's next number opens it."""
    code, out, _ = run(["patients", "add", "--first-name", "Bo", "--last-name", "Example"],
                       capsys)
    patient = out.strip()
    code, out, err = run(["scales", "add", patient, "1", "fugl_meyer", "30", "--by", "K. Lee"],
                         capsys)
    assert (code, err) == (0, "")
    assert out == f"{patient} session 1: Fugl-Meyer UE motor 30/66\n"
    begun = registry_of(data).begin_trial(patient, THESIS_SUBJECT, backend="simulator",
                                          session_number=1)
    assert (begun.session_number, begun.trial_number) == (1, 1)
    assert [s.number for s in registry_of(data).sessions(patient)] == [1]


@pytest.mark.parametrize(("args", "needle"), [
    (["scales", "add", "{code}", "1", "fugl_meyer", "67", "--by", "K"],
     "Fugl-Meyer UE motor = 67 is out of range; give a whole number 0-66"),
    (["scales", "add", "{code}", "1", "fugl_meyer", "A=37", "B=1", "C=1", "D=1", "--by", "K"],
     "A = 37 is out of range; give a whole number 0-36"),
    (["scales", "add", "{code}", "1", "arat", "grasp=3", "--by", "K"], "grip, pinch, gross "
                                                                       "missing"),
    (["scales", "add", "{code}", "1", "ashworth", "elbow_flexors=5", "--by", "K"],
     "is not a grade"),
    (["scales", "add", "{code}", "1", "pain", "-1", "--by", "K"], "Pain (NRS) = -1"),
    (["scales", "add", "{code}", "1", "pain", "three", "--by", "K"], "not a whole number"),
    (["scales", "add", "{code}", "1", "pain", "3", "--by", " "], "rater: give the name"),
    (["scales", "add", "{code}", "1", "pain", "3"], "--by"),
    (["scales", "add", "{code}", "7", "pain", "3", "--by", "K"],
     "has no session 7; give one of their sessions (1) or 2, which opens the next"),
    (["note", "{code}", "7", "typo", "--by", "K"],
     "has no session 7; give one of their sessions (1) or 2, which opens the next"),
    (["scales", "add", "{code}", "0", "pain", "3", "--by", "K"], "not a session number"),
    (["scales", "add", "{code}", "99999999999999999999", "pain", "3", "--by", "K"],
     "not a session number"),
    (["scales", "add", "{code}", "1", "fma", "3", "--by", "K"], "invalid choice"),
    (["note", "{code}", "1", "  ", "--by", "K"], "note: write something"),
    (["note", "{code}", "1", "x", "--trial", "999", "--by", "K"], "999"),
    (["invalid", "1", "--reason", "", "--by", "K"], "reason: say why"),
    (["valid", "1", "--reason", "ok", "--by", "K"], "trial 1 is already valid"),
    (["invalid", "0", "--reason", "x", "--by", "K"], "not a trial id"),
    (["correct", "{code}", "upper_arm_m", "0.9", "--reason", "x", "--by", "K"], "upper_arm_m"),
    (["correct", "{code}", "upper_arm_m", "nan", "--reason", "x", "--by", "K"], "not a finite"),
    (["correct", "{code}", "sex", "f", "--reason", "x", "--by", "K"],
     "sex 'f': give female or male, or none"),
    (["correct", "{code}", "shoulder_m", "1", "--reason", "x", "--by", "K"], "give x,y in m"),
    (["correct", "{code}", "code", "PAAAAAA", "--reason", "x", "--by", "K"], "invalid choice"),
    (["correct", "{code}", "upper_arm_m", "0.30", "--reason", "x", "--by", "K"],
     "nothing to correct"),
    (["corrections", "PAAAAAA"], "no patient has the code"),
])
def test_bad_input_is_one_line_exit_2_and_stores_nothing(data, patient, capsys, args, needle):
    before = _everything(data, patient)
    code, _, err = run([a.replace("{code}", patient) for a in args], capsys)
    assert code == 2
    lines = err.strip().splitlines()
    assert len(lines) == 1, err
    assert needle in lines[0]
    assert _everything(data, patient) == before


def _everything(data, code):
    registry = registry_of(data)
    return (registry.patient(code), registry.scale_entries(code), registry.notes(code),
            registry.invalid_trials(code), registry.corrections(code))
