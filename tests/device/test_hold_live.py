"""Isometric strength through the real loop (issue 31): the loop and recorder processes at
2 ms run a strength trial (two directions, one-second pushes) on the simulator: the file
holds every phase as an `assessment_cue` event on its tick, the hold kept the handle
still, and the task's figures come out of the file as headless."""

import numpy as np
import pytest

from app.assessments.figures import assessment_figures, exercise_of
from app.trials.reader import read_trial
from core.assessment.protocol import protocol
from core.trial import THESIS_SUBJECT
from device.loop.client import DeviceClient
from device.loop.messages import BackendConfig, FaultRaised, TrialEnded
from device.loop.pipeline import PERIOD_S
from device.recording.trialfile import SubjectInfo

pytestmark = pytest.mark.slow

PARAMS = protocol("strength").parameters(THESIS_SUBJECT).replace(n_targets=2, duration_s=1.0)


def test_a_strength_trial_through_the_live_loop(tmp_path):
    with DeviceClient() as client:
        assert client.build(PARAMS, BackendConfig(patient="healthy")).ok
        assert client.connect().ok
        client.wait_for_samples(10)
        path = tmp_path / "strength.h5"
        assert client.start_trial(str(path), SubjectInfo.from_parameters("PSTR01", PARAMS)).ok
        events = client.wait_for(lambda e: isinstance(e, TrialEnded), 60)
        faults = [e.message for e in events if isinstance(e, FaultRaised)]
        assert events[-1].status == "complete", faults
        client.wait_for(lambda e: getattr(e, "kind", "") == "closed", 20)
    data = read_trial(path)
    assert data.status == "complete"
    cues = [e for e in data.events if e["kind"] == "assessment_cue"]
    assert [e["message"] for e in cues] == ["ready", "push", "rest"] * 2
    approach = int(data.summary["approach_s"] / PERIOD_S + 0.5)
    for event, stretch in zip(cues, PARAMS.trajectory().stretches, strict=True):
        assert event["tick"] == approach + round(stretch.start_s / PERIOD_S)
        assert event["values"]["task"] == "strength"
        assert event["values"]["direction_deg"] == dict(stretch.values)["direction_deg"]
    channels = data.channels
    exercise = exercise_of(channels)
    off = np.hypot(*(channels["position"][exercise] - PARAMS.centre_m).T)
    assert off.max() < 0.004
    figures, notes = assessment_figures(channels, PARAMS, exercise)
    assert notes == ()
    assert figures["strength_at_limit_count"] == 2
    assert figures["strength_peak_force_n"] > 3.5


def test_after_stop_the_patient_rests_and_the_idle_robot_keeps_the_handle_in_place(
        tmp_path):
    """Clinic exploration 2 #3: the strength task stopped early (the weak patient), then no
    trial running: the virtual patient's clock ran on and its pushes went on against the
    robot at zero torque (as the real robot is between trials, docs/safety.md), taking the
    handle out of the exercise area until a workspace fault latched. Now the patient rests
    with the trial's end, as a person lets go of the push: the handle stays where it was
    for as long as the rest of the timetable, and nothing latches."""
    params = PARAMS.replace(n_targets=4)
    with DeviceClient() as client:
        assert client.build(params, BackendConfig(patient="weak")).ok
        assert client.connect().ok
        client.wait_for_samples(10)
        path = tmp_path / "stopped.h5"
        assert client.start_trial(str(path), SubjectInfo.from_parameters("PSTR02", params)).ok
        client.wait_for_samples(int(1.0 / PERIOD_S))  # the approach and the first "ready"
        assert client.stop().ok
        client.wait_for(lambda e: getattr(e, "kind", "") == "closed", 20)
        client.live_records()  # the trial's; what follows is idle
        seen = client.wait_for_samples(int(params.trajectory().total_duration_s / PERIOD_S))
        idle = client.live_records()
    assert not [e.message for e in seen if isinstance(e, FaultRaised)]
    assert len(idle) > 1000
    moved = np.hypot(*(idle["position"] - idle["position"][0]).T)
    assert moved.max() < 0.002
