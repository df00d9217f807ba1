"""A trial's dose is what the patient's hand did (app.plans.dose.trial_dose): in the
transparent mode nothing moves the hand along the path, so a passive patient, whose hand
stays put while the reference runs on the clock, made no movement; in a guiding mode the
robot takes the hand round and every planned movement is made."""

from __future__ import annotations

import pytest

from app.plans.dose import BlockDose, RunDose, trial_dose
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


@pytest.mark.parametrize("duration_s", [1.5, 4.0])
def test_a_healthy_hand_s_last_lap_in_the_transparent_mode_counts(tmp_path, duration_s):
    """A plan ended "3 of 4 movements" although its path game's last round scored a clean
    lap: the hand's last movement was held to the reference's 2 mm arrival, and the
    healthy virtual patient's hand came within 3-4.5 mm of the D's end (at a 4 s pace),
    or passed it by and swung 4 cm on (at 1.5 s), so no trial's last lap counted."""
    parameters = TrialParameters(shape="d", duration_s=duration_s, repetitions=2,
                                 assist="transparent", assistance_level=0.0, game="path")
    path = tmp_path / "trial.h5"
    simulate_to_file(parameters, path, patient="healthy", seed=3)
    assert trial_dose(path).movements == 2


def test_the_time_done_is_shown_beside_the_planned_never_as_an_overrun():
    """The Progress tab read "0:51 of 0:50 active" after a plan done in full: the
    as-needed mode's exercise runs on past the clock by up to the guidance's delay (the
    test above), and "51 of 50" read as an overrun. Done and planned are each said for
    what they are, in the tab's line, the session report's and the dose table."""
    dose = RunDose(4, "complete", [
        BlockDose(1, "Reaching game", 24, 36.0, 60.0, 24, 36.6, 60.0),
        BlockDose(2, "Path game", 6, 14.0, 0.0, 6, 14.3, 0.0)])
    table = dose.table()
    assert not any("0:51 of 0:50" in line for line in table)
    assert table[0].split()[-4:] == ["active", "(planned)", "rest", "(planned)"]
    assert table[1].split()[-4:] == ["0:37", "(0:36)", "1:00", "(1:00)"]
    assert table[-1].split()[-4:] == ["0:51", "(0:50)", "1:00", "(1:00)"]
    assert dose.summary() == "30 of 30 movements, 0:51 active (0:50 planned), 1:00 of rest"
