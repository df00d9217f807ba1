"""The Registration tab's line on a patient's stored measurements names what is not stored
(it said "For the others, give them in the Parameters tab": a therapist had to guess that
"the others" was the shoulder position, which `rehab patients add` leaves out unless
--shoulder is given)."""

from types import SimpleNamespace

from ui.tabs.patient_words import measurements


def _patient(**given):
    values = dict(body_mass_kg=None, upper_arm_m=None, forearm_m=None, shoulder_m=None)
    values.update(given)
    return SimpleNamespace(**values)


def test_the_measurement_not_stored_is_named():
    line = measurements(_patient(body_mass_kg=70.0, upper_arm_m=0.30, forearm_m=0.27))
    assert line.startswith("Stored: body mass 70.0 kg, upper arm 30.0 cm, forearm 27.0 cm.")
    assert "Not stored: the shoulder position; give it in the Parameters tab" in line


def test_several_not_stored_and_none_stored():
    line = measurements(_patient(body_mass_kg=70.0, upper_arm_m=0.30))
    assert "Not stored: the forearm and the shoulder position; give them" in line
    assert "No measurements stored: give the body mass, arm lengths and shoulder position" \
        in measurements(_patient())


def test_all_stored_says_nothing_missing():
    line = measurements(_patient(body_mass_kg=70.0, upper_arm_m=0.30, forearm_m=0.27,
                                 shoulder_m=(-0.12, 0.73)))
    assert "Not stored" not in line
    assert line.endswith("The Parameters tab now uses them.")
