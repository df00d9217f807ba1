"""What a therapist types for a clinical scale, refused in the scale's name (clinic
exploration 2 #5: "fatigue = '3.5' is not a whole number" named the registry's key)."""

import pytest

from app.errors import InvalidRecordError
from app.records.scales import ARAT, ASHWORTH, FATIGUE, FUGL_MEYER, PAIN
from app.records.typed import shown_value, typed_scores, typed_shown_value, typed_value


@pytest.mark.parametrize(("scale", "scores", "line"), [
    (FATIGUE, ["3.5"], "Fatigue (NRS): '3.5' is not a whole number; give a whole number "
                       "from 0 to 10"),
    (FATIGUE, ["3", "4"], "Fatigue (NRS): give a whole number from 0 to 10, not 3 4"),
    (ARAT, ["grasp=x"], "ARAT grasp: 'x' is not a whole number; give a whole number from 0 "
                        "to 18"),
    # nan, inf and nothing said what was wrong but not what to give (a part's, a subscale's
    # and an item's range too), and int() took '1_0' as 10
    (PAIN, ["nan"], "Pain (NRS): 'nan' is not a whole number; give a whole number from 0 "
                    "to 10"),
    (PAIN, [" "], "Pain (NRS): give a whole number from 0 to 10, not nothing"),
    (PAIN, ["1_0"], "Pain (NRS): '1_0' is not a whole number; give a whole number from 0 "
                    "to 10"),
    (FUGL_MEYER, [""], "Fugl-Meyer UE motor: give one total (a whole number from 0 to 66) "
                       "or KEY=VALUE scores, not nothing"),
    (FUGL_MEYER, ["A=nan", "B=1", "C=1", "D=1"], "Fugl-Meyer UE motor A: 'nan' is not a "
                                                 "whole number; give a whole number from 0 "
                                                 "to 36"),
    (FUGL_MEYER, ["A="], "Fugl-Meyer UE motor A: '' is not a whole number; give a whole "
                         "number from 0 to 36"),
    (FUGL_MEYER, ["d_time=inf"], "Fugl-Meyer UE motor d_time: 'inf' is not a whole number; "
                                 "give a whole number from 0 to 2"),
    (FUGL_MEYER, ["=3"], "Fugl-Meyer UE motor: '=3' has no KEY before '='; give KEY=VALUE "
                         "scores"),
    (ASHWORTH, [" "], "Modified Ashworth has no total: give GROUP=GRADE for each muscle "
                      "group measured (shoulder_adductors, shoulder_internal_rotators, "
                      "elbow_flexors, elbow_extensors, forearm_pronators, wrist_flexors, "
                      "finger_flexors), the grade one of 0, 1, 1+, 2, 3, 4"),
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
    ("upper_arm_m", "thirty", "Upper arm 'thirty' is not a number; give 15 to 50 cm "
                              "(shoulder to elbow of an adult), or none"),
    ("forearm_m", "nan", "Forearm 'nan' is not a finite number; give 15 to 50 cm (elbow to "
                         "wrist of an adult), or none"),
    ("forearm_m", "3_0", "Forearm '3_0' is not a number; give 15 to 50 cm"),  # float(): 30
    ("last_name", " ", "Last name: nothing given; give the new value, or none to clear it"),
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


# -- the command line's `rehab correct`: the registry's names, SI ---------------------------

@pytest.mark.parametrize(("field", "text", "line"), [
    # 'nan', 'inf' and nothing said what was wrong but not the range to give
    ("upper_arm_m", "nan", "upper_arm_m 'nan' is not a finite number; give 0.15 to 0.5 m "
                           "(shoulder to elbow of an adult), or none"),
    ("body_mass_kg", "-inf", "body_mass_kg '-inf' is not a finite number; give 20 to 250 kg "
                             "(Winter's segment proportions hold for adults), or none"),
    ("forearm_m", "", "forearm_m: nothing given; give the new value, or none to clear it"),
    ("upper_arm_m", "0.3_0", "upper_arm_m '0.3_0' is not a number; give 0.15 to 0.5 m"),
    ("upper_arm_m", "0.9", "upper_arm_m 0.9 m is out of range: give 0.15 to 0.5 m"),
    ("shoulder_m", "nan,0.7", "shoulder_m 'nan' is not a finite number; give -1.5 to 1.5 m, "
                              "or none"),  # was the registry's 'allowed: a finite number m'
    ("shoulder_m", "-0.1", "shoulder_m '-0.1': give x,y in m (e.g. -0.12,0.73)"),
    ("birth_year", "nan", "birth_year: 'nan' is not a whole number; give a year 1900-"),
    ("birth_year", "1800", "birth_year 1800: give a year 1900-"),  # not the registry's 'None'
    ("sex", "f", "sex 'f': give female or male, or none"),
    # an empty name cleared it, as 'none' does: an unset shell variable erased a name
    ("first_name", "", "first_name: nothing given; give the new value, or none to clear it"),
])
def test_a_correction_on_the_command_line_says_what_to_give(field, text, line):
    with pytest.raises(InvalidRecordError) as refused:
        typed_value(field, text)
    assert str(refused.value).startswith(line)


@pytest.mark.parametrize(("field", "text", "value"), [
    ("upper_arm_m", " 0.31 ", 0.31), ("shoulder_m", "-0.12,0.73", (-0.12, 0.73)),
    ("birth_year", "1961", 1961), ("sex", "Female", "female"), ("forearm_m", "none", None),
    ("first_name", "Ada", "Ada"),
])
def test_a_correction_on_the_command_line_is_taken_in_si(field, text, value):
    assert typed_value(field, text) == value
