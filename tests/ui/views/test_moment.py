"""A replayed moment in a therapist's words and units, without Qt."""

from __future__ import annotations

import datetime
import math

import numpy as np
import pytest

from app.records.registry import Trial
from device.loop.pipeline import PHASE_APPROACH, PHASE_EXERCISE
from device.recording.record import RECORD_DTYPE
from device.safety.faults import Fault
from ui.views.moment import MOMENT_ROWS, describe_trial, moment
from ui.views.trialview import TrialView


@pytest.fixture
def view() -> TrialView:
    records = np.zeros(4, dtype=RECORD_DTYPE)
    records["time"] = [0.0, 0.002, 0.004, 0.006]
    records["phase"] = [PHASE_APPROACH, PHASE_EXERCISE, PHASE_EXERCISE, PHASE_EXERCISE]
    records["position"] = [[-0.30, 0.30], [-0.301, 0.3025], [-0.3, 0.3], [-0.3, 0.3]]
    records["force"] = [[0.0, 0.0], [3.0, 4.0], [3.0, -4.0], [0.01, 0.0]]
    # Within the 20° tolerance, against the path, too weak to have a direction.
    records["force_angle"] = [np.nan, math.radians(5.0), math.radians(120.0), np.nan]
    records["subject_angle_isb"] = [[0.0, 0.0], [math.radians(30.0), math.radians(-45.5)],
                                    [0.0, 0.0], [0.0, 0.0]]
    records["subject_torque"] = [[0.0, 0.0], [1.234, -0.5], [0.0, 0.0], [0.0, 0.0]]
    records["fault"] = [0, 0, 0, int(Fault.ESTOP)]
    return TrialView.from_records(records)


def test_every_row_is_filled_in_display_units(view):
    said = moment(view, 1)
    assert set(said) == {key for key, _ in MOMENT_ROWS}
    assert said["phase"] == "exercise"
    assert said["position"] == "x −30.1 cm, y 30.2 cm"
    assert said["force"] == "5.00 N, within 20° of the path's direction"
    assert said["angles"] == "30.0°, −45.5°"
    assert said["torques"] == "1.23 N·m, −0.50 N·m"
    assert said["fault"] == "no fault"


def test_the_push_is_judged_only_in_the_exercise(view):
    assert moment(view, 0)["phase"] == "moving to the start"
    assert moment(view, 0)["force"] == "0.00 N"
    assert moment(view, 2)["force"].endswith(", not along the path")
    assert moment(view, 3)["force"].endswith(", too light to tell its direction")


def test_a_fault_is_named_by_its_cause(view):
    assert moment(view, 3)["fault"] == "Emergency stop pressed"


def test_a_trial_in_the_list_reads_numbers_time_and_status():
    started = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=datetime.UTC)
    trial = Trial(7, "PABC234", 2, started.date(), 3, {}, "trials/x.h5", {}, "faulted",
                  started, None, "simulator", None)
    local = started.astimezone().strftime("%d %b %Y %H:%M")
    assert describe_trial(trial) == f"Session 2, trial 3 — {local} — safety stop"


def test_a_trial_another_station_recorded_says_which_in_the_list():
    """A patient seen at robot-1 and robot-2: robot-1's list names robot-2's trials."""
    import dataclasses

    started = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=datetime.UTC)
    trial = dataclasses.replace(
        Trial(7, "PABC234", 2, started.date(), 3, {}, "trials/x.h5", {}, "complete",
              started, None, "simulator", None), station="robot-2")
    local = started.astimezone().strftime("%d %b %Y %H:%M")
    assert describe_trial(trial, "robot-1") == \
        f"Session 2, trial 3 — {local} — complete — at robot-2"
    assert describe_trial(trial, "robot-2") == f"Session 2, trial 3 — {local} — complete"


@pytest.mark.parametrize(("changes", "named"), [
    ({"game": "reach", "shape": "reach"}, "Reaching game · "),
    ({"game": "path"}, "Path game · "),
    ({"assessment": "circle", "shape": "circle", "radius_m": 0.07, "assist": "transparent"},
     "Assessment: Circle drawing · Transparent · circle, r 7.0 cm"),
    ({}, "Thesis mode · D shape, r 10.0 cm"),
])
def test_a_trial_in_the_list_says_which_game_or_assessment_it_was(changes, named):
    """Found driving the window (brief hO): Replay's list said only numbers, time and
    status, so a game's round or an assessment task read as any trial of its shape. Its
    second line names it as the Progress tab names its series."""
    from core.trial import TrialParameters

    started = datetime.datetime(2024, 5, 2, 9, 30, tzinfo=datetime.UTC)
    parameters = TrialParameters().replace(**changes).to_dict()
    trial = Trial(7, "PABC234", 2, started.date(), 3, parameters, "trials/x.h5", {},
                  "complete", started, None, "simulator", None)
    first, second = describe_trial(trial).split("\n")
    assert first.startswith("Session 2, trial 3 — ")
    assert second.startswith(named), second
    if not changes:
        assert "game" not in second
        assert "Assessment" not in second
