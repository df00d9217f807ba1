"""What a therapist types for a clinical scale, refused in the scale's name (clinic
exploration 2 #5: "fatigue = '3.5' is not a whole number" named the registry's key)."""

import pytest

from app.errors import InvalidRecordError
from app.records.scales import ARAT, FATIGUE
from app.records.typed import typed_scores


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
