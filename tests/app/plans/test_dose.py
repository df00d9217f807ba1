"""A trial's dose is what the patient's hand did (app.plans.dose.trial_dose): in the
transparent mode nothing moves the hand along the path, so a passive patient, whose hand
stays put while the reference runs on the clock, made no movement; in a guiding mode the
robot takes the hand round and every planned movement is made."""

from __future__ import annotations

import pytest

from app.plans.dose import trial_dose
from app.trials.headless import simulate_to_file
from core.plan import movements_per_lap
from core.trial import TrialParameters

REACH = TrialParameters(shape="reach", radius_m=0.06, duration_s=3.0, repetitions=2)


@pytest.mark.parametrize(("assist", "patient", "movements"), [
    ("transparent", "passive", 0),  # the reference's count would say 4
    ("as-needed", "passive", 4),
    ("thesis", "weak", 4),
])
def test_the_dose_counts_the_hand_s_movements(tmp_path, assist, patient, movements):
    parameters = REACH.replace(assist=assist)
    path = tmp_path / "trial.h5"
    simulate_to_file(parameters, path, patient=patient, seed=3)
    dose = trial_dose(path)
    assert 2 * movements_per_lap("reach") == 4
    assert dose.movements == movements
    # the exercise phase's time: the clock's 6 s, and in the as-needed mode up to the
    # guidance's delay more while the reference catches the hand up at the path's end
    assert 2 * 3.0 - 0.01 <= dose.active_s <= 2 * 3.0 + 0.5
