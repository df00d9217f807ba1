"""`rehab plan …` as a therapist types it: the templates, a template copied to a patient and
a block changed for the day, the plan shown; every bad input one line, exit 2. (`plan run`
and `plan dose` on the live loop: tests/app/plans/test_live_plan.py runs the same driver.)"""

import pytest

from tests.app.cli.running import run


@pytest.fixture
def patient(data, capsys):
    code, out, _ = run(["patients", "add", "--first-name", "Ada", "--body-mass", "91",
                        "--upper-arm", "0.3048", "--forearm", "0.3048", "--side", "right",
                        "--shoulder", "-0.12", "0.73"], capsys)
    assert code == 0
    return out.strip()


def test_a_template_copied_changed_for_today_and_shown(patient, capsys):
    code, out, _ = run(["plan", "templates"], capsys)
    assert code == 0
    assert "first-session: First session." in out
    code, out, _ = run(["plan", "copy", "first-session", patient], capsys)
    assert code == 0
    assert out.startswith(f"Plan 1 for patient {patient}: First session")
    code, out, _ = run(["plan", "change", patient, "2", "repetitions=5", "rest_s=30",
                        "assistance_level=0.6"], capsys)
    assert code == 0
    assert "2. Circle: circle, 5 laps at 5 s a lap, as-needed 60 %, tolerance 20°, rest 30 s" \
        in out
    code, out, _ = run(["plan", "change", patient, "1", "active_s=120"], capsys)
    assert code == 0
    assert "2 min (24 laps)" in out
    code, out, _ = run(["plan", "show", patient], capsys)
    assert code == 0
    assert "Plan 3 of patient" in out
    assert "changed from plan 2, template first-session" in out
    assert "planned: 39 movements" in out  # 24 laps of the D, 5 circles, 5 reaches × 2
    code, out, _ = run(["plan", "show", patient, "--plan", "1"], capsys)
    assert "1. Warm-up on the D: d, 3 laps" in out


@pytest.mark.parametrize(("argv", "words"), [
    (["plan", "copy", "nope", "{code}"], "no plan template 'nope'; the templates are: "),
    (["plan", "show", "{code}"], "has no plan: copy a template to them first"),
    (["plan", "run", "{code}"], "has no plan: copy a template to them first"),
    (["plan", "dose", "{code}"], "has run no plan yet"),
    (["plan", "copy", "reaching", "PNOBODY"], "no patient has the code 'PNOBODY'"),
])
def test_bad_input_is_one_line_and_exit_2(patient, capsys, argv, words):
    code, _, err = run([a.format(code=patient) for a in argv], capsys)
    assert code == 2
    assert words in err
    assert err.count("\n") == 1


@pytest.mark.parametrize(("change", "words"), [
    (["9", "rest_s=3"], "block 9: plan 1 has blocks 1-3"),
    (["1", "speed=3"], "'speed=3': give FIELD=VALUE with a block's field"),
    (["1", "rest_s=soon"], "rest_s='soon': give a number"),
    (["1", "rest_s=-4"], "block 1.rest_s = -4 is not allowed"),
    (["1", "repetitions=2.5"], "repetitions='2.5': give a number"),
    (["1", "shape=spiral"], "block 1.shape = 'spiral'"),
])
def test_a_bad_change_is_refused_in_one_line_and_keeps_the_plan(patient, capsys, change,
                                                                words):
    assert run(["plan", "copy", "first-session", patient], capsys)[0] == 0
    code, _, err = run(["plan", "change", patient, *change], capsys)
    assert code == 2
    assert words in err
    assert err.count("\n") == 1
    _, out, _ = run(["plan", "show", patient], capsys)
    assert "Plan 1 of patient" in out  # no new plan was saved


def test_a_template_copied_to_a_patient_it_does_not_fit_is_fitted_and_says_how(data, capsys):
    """Shoulder (-12, 73) cm and an arm reaching 57 cm: the First session's 12 cm reach
    went 57.9 cm from the shoulder and the plan was refused at Start."""
    code, out, _ = run(["patients", "add", "--first-name", "Bea", "--body-mass", "70",
                        "--upper-arm", "0.30", "--forearm", "0.27", "--side", "right",
                        "--shoulder", "-0.12", "0.73"], capsys)
    patient = out.strip()
    code, out, _ = run(["plan", "copy", "first-session", patient], capsys)
    assert code == 0
    assert ("  fitted to the patient: block 3 (Forward reach): radius 0.05 m, not 0.06 m, "
            "to stay within this patient's reach and the robot's") in out
    code, out, _ = run(["plan", "show", patient], capsys)
    assert "3. Forward reach: reach" in out
