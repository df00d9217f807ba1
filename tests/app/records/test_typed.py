"""What a therapist types for a clinical scale, refused in the scale's name (clinic
exploration 2 #5: "fatigue = '3.5' is not a whole number" named the registry's key)."""

import pytest

from app.errors import InvalidRecordError
from app.records.scales import ARAT, FATIGUE
from app.records.typed import shown_value, typed_scores, typed_shown_value


@pytest.mark.parametrize(("scale", "scores", "line"), [
    (FATIGUE, ["3.5"], "Fatigue (NRS): '3.5' is not a whole number; give a whole number "
                       "from 0 to 10"),
    (FATIGUE, ["3", "4"], "Fatigue (NRS): give one total or KEY=VALUE scores, not 3 4"),
    (ARAT, ["grasp=x"], "ARAT grasp: 'x' is not a whole number"),
])
def test_a_score_that_cannot_be_read_is_refused_in_the_scale_s_name(scale, scores, line):
    with pytest.raises(InvalidRecordError) as refused:
        typed_scores(scale, scores)
    assert str(refused.value) == line


# -- the Correct row: the Registration tab's names and units ----------------------------------

@pytest.mark.parametrize(("field", "text", "value", "said"), [
    ("upper_arm_m", "30", 0.30, "30.0 cm"),
    ("upper_arm_m", " 15 ", 0.15, "15.0 cm"),  # the range's ends, as the registry takes them
    ("forearm_m", "50", 0.50, "50.0 cm"),
    ("shoulder_m", "-12, 73", (-0.12, 0.73), "(-12.0, 73.0) cm"),
    ("body_mass_kg", "82.5", 82.5, "82.5 kg"),
    ("birth_year", "1961", 1961, "1961"),
    ("sex", "Female", "female", "female"),  # as the tab's list says it
    ("side", "none", None, "none"),
    ("last_name", "Lovelace", "Lovelace", "Lovelace"),
])
def test_a_correction_is_typed_in_the_units_the_registration_tab_shows(field, text, value,
                                                                        said):
    """The Correct row took SI values under the registry's names (`upper_arm_m` 0.30)
    where the Registration tab shows and takes cm: a value is typed in the tab's units and
    stored in SI, and said back in the tab's units."""
    typed = typed_shown_value(field, text)
    assert typed == pytest.approx(value) if isinstance(value, float | tuple) else \
        typed == value
    assert shown_value(field, typed) == said


@pytest.mark.parametrize(("field", "text", "line"), [
    ("upper_arm_m", "0.30", "Upper arm 0.3 cm is out of range: give 15 to 50 cm (shoulder "
                            "to elbow of an adult), or none"),  # metres typed, as before
    ("upper_arm_m", "thirty", "Upper arm 'thirty' is not a number; give it in cm"),
    ("forearm_m", "nan", "Forearm 'nan' is not a finite number"),
    ("shoulder_m", "12", "Shoulder '12': give x,y in cm (e.g. -12,73)"),
    ("shoulder_m", "-12,200", "Shoulder 200 cm is out of range: give -150 to 150 cm, or "
                              "none"),
    ("body_mass_kg", "8", "Body mass 8 kg is out of range: give 20 to 250 kg (Winter's "
                          "segment proportions hold for adults), or none"),
    ("birth_year", "1800", "Year of birth 1800: give a year 1900-"),
    ("birth_year", "19a1", "Year of birth: '19a1' is not a whole number"),
    ("handedness", "ambidextrous", "Handedness 'ambidextrous': give right or left, or none"),
])
def test_a_correction_refused_names_the_field_and_unit_as_the_tab_does(field, text, line):
    with pytest.raises(InvalidRecordError) as refused:
        typed_shown_value(field, text)
    assert str(refused.value).startswith(line)
    assert "_m" not in str(refused.value)
