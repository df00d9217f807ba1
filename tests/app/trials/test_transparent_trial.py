"""The transparent mode in closed loop on the simulator (issue 30, Transparent robot): the
hand feels less of the robot than with its motors off, the robot moves no one (a passive
patient stays where the exercise found them), the safety limits still stop it, and a
trial in it is recorded, read back, registered and reported as what it was. Outcomes of
headless trials (app.trials.headless), never timings."""

from __future__ import annotations

import math

import numpy as np
import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.build import content_for_registry_trial, report_for_registry_trial
from app.trials.headless import simulate
from app.trials.progression import TRANSPARENT_REASON
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.engine import run_trial
from device.loop.pipeline import PHASE_EXERCISE, PHASE_HOLD, TickPipeline, TrialPlan
from device.safety.faults import Fault
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor
from device.sim.mover import MOVER, MOVER_OPTIONS, circle_at_speed, felt_force
from device.sim.simulator import SimulatorBackend
from tests.app.reports.made import page_texts, register

TRANSPARENT = THESIS_SUBJECT.replace(assist="transparent")
MOTORS_OFF = TRANSPARENT.replace(
    gains="transparent.inertia=0; transparent.friction=0; transparent.stiffness=0")


def moved(base, speed_m_s=0.3, **options):
    params = circle_at_speed(base, speed_m_s)
    trial = simulate(params, patient=MOVER, seed=0, plant="realistic",
                     patient_options=MOVER_OPTIONS, **options)
    assert trial.status == "complete"
    return trial, felt_force(trial.records, params)


def test_the_hand_feels_less_of_the_robot_than_with_its_motors_off():
    """A firm arm moving the handle round a circle at 0.3 m/s on the realistic plant felt
    0.62 N RMS (1.17 N peak) in the transparent mode and 1.84 N (3.00 N) with the motors
    off (bench/transparency.py): at most two thirds of it here, whatever the drift of
    the defaults."""
    transparent, felt = moved(TRANSPARENT)
    off, floor = moved(MOTORS_OFF)
    exercise = off.records["phase"] == PHASE_EXERCISE
    assert np.all(off.records["torque_applied"][exercise] == 0.0)  # motors off indeed
    assert felt.rms_N < 2 / 3 * floor.rms_N, (felt, floor)
    assert felt.peak_N < 2 / 3 * floor.peak_N, (felt, floor)
    # the arm, not the robot, kept the pace in both
    for kept in (felt, floor):
        assert kept.speed_m_s == pytest.approx(0.3, rel=0.15), kept
    # the robot's torque did work in the exercise: this is compensation, not motors off
    exercise = transparent.records["phase"] == PHASE_EXERCISE
    assert np.abs(transparent.records["torque_applied"][exercise]).max() > 0.05


@pytest.mark.parametrize("plant", ["realistic", "ideal"])
def test_a_passive_patient_is_not_moved_along_the_path(plant):
    """No guidance: a relaxed arm stays where the exercise found it through two laps of
    the D, while the as-needed mode at full help takes the same arm round the path (so the
    test can tell)."""
    def travelled_m(params):
        trial = simulate(params.replace(repetitions=2), patient="passive", seed=0,
                         plant=plant)
        assert trial.status == "complete"
        exercise = trial.records["phase"] == PHASE_EXERCISE
        path = trial.records["position"][exercise]
        return float(np.hypot(*np.diff(path, axis=0).T).sum()), trial

    still, trial = travelled_m(TRANSPARENT)
    guided, _ = travelled_m(THESIS_SUBJECT.replace(assist="as-needed", assistance_level=1.0))
    assert still < 0.005, still
    assert guided > 0.5, guided  # two laps of a D of radius 10 cm: about 1 m
    exercise = trial.records["phase"] == PHASE_EXERCISE
    assert np.abs(trial.records["torque_applied"][exercise]).max() < 0.01


def test_the_hold_does_not_pull_the_hand_to_the_paths_end():
    """After the exercise the transparent mode stays transparent (core.control.transparent):
    the wrong-way patient, who ends two laps of the D 24 mm from the path's end, is not
    pulled there (0.31 N·m at most, seed 0), where the as-needed mode's hold runs the
    controller at the drives' rating (2.2 N·m) to hold its hand at the end."""
    def hold_torque(params):
        trial = simulate(params.replace(repetitions=2), patient="wrong_way", seed=0)
        assert trial.status == "complete"
        hold = trial.records["phase"] == PHASE_HOLD
        assert hold.sum() == 250  # 0.5 s
        return float(np.abs(trial.records["torque_applied"][hold]).max())

    assert hold_torque(TRANSPARENT) < 0.5
    assert hold_torque(THESIS_SUBJECT.replace(assist="as-needed")) > 1.5


def supervised(params, limits: SafetyLimits):
    """A headless compiled trial of the mover on `params` under `limits` (what `simulate`
    runs, with the supervisor's limits chosen)."""
    plan = TrialPlan.build(params)
    backend = SimulatorBackend.from_trial(params, MOVER, seed=0, robot=plan.robot,
                                          patient_options=MOVER_OPTIONS, compiled=True,
                                          plant="realistic")
    pipeline = TickPipeline(plan, compiled=True)
    return run_trial(backend, pipeline, SafetySupervisor(plan.robot, limits))


@pytest.mark.parametrize(("change", "fault"), [
    ("speed", Fault.EE_SPEED),
    ("area", Fault.WORKSPACE),
])
def test_the_safety_limits_still_stop_a_transparent_trial(change, fault):
    """The supervisor stays in this mode: the handle moved faster than the limit, or out of
    the exercise area, stops the trial in the exercise with exactly zero torque from the
    tick it was found."""
    params = circle_at_speed(TRANSPARENT, 0.3)
    limits = SafetyLimits()
    if change == "speed":
        limits = SafetyLimits(ee_speed_limit_m_s=0.2)
    else:
        # an area round the first half of the circle only: the arm carries the handle out
        points = params.path().points()
        limits = limits.around_path(points[: len(points) // 2], margin_m=0.02)
    outcome = supervised(params, limits)
    assert outcome.status == "faulted"
    records = outcome.records
    at = int(np.flatnonzero(records["fault"] != 0)[0])
    assert Fault(int(records["fault"][at])) is fault
    assert records["phase"][at] == PHASE_EXERCISE
    assert np.all(records["torque_applied"][at:] == 0.0)
    assert outcome.fault_tick == at


def test_a_transparent_trial_is_recorded_read_back_and_reported_as_it_ran(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", side="right").code
    params = TRANSPARENT.replace(repetitions=2, assistance_level=0.6)
    assert params.assistance_level == 0.0  # nothing acts on a level in this mode
    trial_id = register(registry, code, params, session=1, patient="healthy", seed=3)
    record = registry.trial(trial_id)
    assert record.assist == "transparent"

    data = read_trial(registry.trial_path(record))
    assert data.parameters == params
    assert data.assistance == {"mode": "transparent", "level": 0.0, "inertia": 0.7,
                               "friction": 0.9, "stiffness": 1.0}
    np.testing.assert_array_equal(data.channels["assistance_level"], 0.0)
    assert data.assistance_in_effect().summary() == "0 %"

    content = content_for_registry_trial(registry, trial_id)
    metrics = content.metrics
    distance_mm = max(1, round(1000 * math.hypot(metrics.rmse_x_m, metrics.rmse_y_m)))
    assert content.plain[0].text == (f"Your hand kept on average {distance_mm} mm from the "
                                     "moving ring.")
    assert not any("pushed in the right direction" in line.text.lower()
                   for line in content.plain)
    pdf = report_for_registry_trial(registry, trial_id, tmp_path / "report.pdf")
    pages = page_texts(pdf)
    assert "Your hand kept on average" in pages[0]
    assert "transparent exercise (no assistance)" in " ".join(pages)

    pending = registry.pending_proposal(code)
    assert pending is not None
    assert pending.proposal["change"] == "none"
    assert pending.proposal["reason"] == TRANSPARENT_REASON
