"""The per-tick pipeline: record layout, approach planning, and the subject model per tick
agreeing with the vectorised one."""

import math

import numpy as np
import pytest

from core.interaction import subject_state
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import (
    PHASE_APPROACH,
    PHASE_EXERCISE,
    TickPipeline,
    TrialPlan,
    idle_record,
)
from device.recording.record import RECORD_DTYPE, RecordLog, flat_names
from device.sim.simulator import SimulatorBackend

PARAMS = THESIS_SUBJECT.replace(repetitions=1, duration_s=3.0, timing="minimum_jerk")


def run_ticks(n, start_offset=(0.0, 0.0)):
    plan = TrialPlan.build(PARAMS)
    sim = SimulatorBackend.from_trial(PARAMS, "healthy", seed=2)
    sim.open()
    pipeline = TickPipeline(plan)
    log = RecordLog()
    reading = sim.read(0.0)
    pipeline.begin(reading.q1_rad + start_offset[0], reading.q2_rad + start_offset[1])
    for k in range(n):
        if k:
            reading = sim.read(k * plan.period_s)
        tau = pipeline.control(k, reading)
        sim.write(*tau)
        log.append(pipeline.record(k, reading, k * 0.002, 0.0, 0.0, tau, 3, 0))
    sim.close()
    return plan, pipeline, log.to_array()


def test_record_has_one_number_per_flat_field():
    plan, _, records = run_ticks(5)
    assert records.dtype == RECORD_DTYPE
    assert len(flat_names()) == 53
    np.testing.assert_array_equal(records["tick"], np.arange(5))
    np.testing.assert_allclose(records["time"], np.arange(5) * 0.002)
    x, y = plan.robot.position(*records["robot_angle"].T)
    np.testing.assert_allclose(records["position"], np.column_stack((x, y)))
    assert (records["state"] == 3).all()


def test_per_tick_subject_model_equals_the_vectorised_one():
    # the tick's record runs the compiled kernel on floats; analyses run the same
    # kernel interpreted on whole arrays: one formula, the same numbers
    plan, _, records = run_ticks(600)
    q, qd, qdd = (records[n] for n in ("robot_angle", "robot_rate", "robot_acceleration"))
    f = records["force_sensor"]
    s = subject_state(plan.robot, plan.parameters.arm(), q[:, 0], q[:, 1], qd[:, 0],
                      qd[:, 1], qdd[:, 0], qdd[:, 1], f[:, 0], f[:, 1])
    for name, pair in (
        ("subject_angle", (s.shoulder_rad, s.elbow_rad)),
        ("subject_rate", (s.shoulder_rate_rad_s, s.elbow_rate_rad_s)),
        ("subject_acceleration", (s.shoulder_acc_rad_s2, s.elbow_acc_rad_s2)),
        ("subject_torque", (s.shoulder_torque_Nm, s.elbow_torque_Nm)),
        ("subject_angle_isb", (s.isb_shoulder_rad, s.isb_elbow_rad)),
    ):
        np.testing.assert_allclose(records[name], np.column_stack(pair), rtol=1e-10,
                                   atol=1e-10, err_msg=name)
    np.testing.assert_array_equal(records["singular"], s.damped)
    assert np.isfinite(records["subject_torque"]).all()


def test_approach_from_elsewhere_then_exercise():
    plan, pipeline, records = run_ticks(10, start_offset=(0.05, -0.03))
    assert pipeline.approach_ticks >= round(1.0 / 0.002)
    assert (records["phase"] == PHASE_APPROACH).all()
    # the approach ends exactly where the exercise starts
    rows = plan.approach_rows(*(records["robot_angle"][0] + (0.05, -0.03)))
    assert rows[-1][0:2] == pytest.approx(plan.start_point_m, abs=1e-4)
    assert math.hypot(rows[-1][2], rows[-1][3]) < 1e-3


def test_no_approach_when_already_at_the_start():
    _, pipeline, records = run_ticks(3)
    assert pipeline.approach_ticks == 0
    assert (records["phase"] == PHASE_EXERCISE).all()


def test_a_trial_started_with_a_torque_ramp_holds_the_start_through_it():
    """The live loop begins a trial with its supervisor's restart ramp (docs/safety.md
    H3) as the shortest approach: a handle already at the start is held there, at rest,
    and the exercise's reference starts when the drives have their full torque."""
    plan = TrialPlan.build(PARAMS)
    q = plan.robot.ik_terms(*plan.start_point_m)
    still = plan.approach_table(*q, still_s=0.5)
    assert len(still) == round(0.5 / plan.period_s)
    first = plan.reference(0, 1)[0]
    np.testing.assert_array_equal(still[:, [0, 1, 4, 5, 6, 7]],
                                  np.tile(first[[0, 1, 4, 5, 6, 7]], (len(still), 1)))
    assert not still[:, [2, 3, 8, 9, 10, 11]].any()  # no velocity, no acceleration
    assert len(plan.approach_table(*q)) == 0  # headless runs have no ramp, nor this
    away = plan.approach_table(q[0] + 0.05, q[1] - 0.03, still_s=0.5)
    assert len(away) == len(plan.approach_table(q[0] + 0.05, q[1] - 0.03))  # >= 1 s anyway


def test_idle_record_fits_the_layout():
    plan = TrialPlan.build(PARAMS)
    sim = SimulatorBackend.from_trial(PARAMS, "passive")
    sim.open()
    reading = sim.read(0.0)
    log = RecordLog()
    log.append(idle_record(plan.robot, PARAMS.arm(), 0, reading, 0.0, 1e-5, 2e-5, 2, 0))
    record = log.to_array()[0]
    assert record["phase"] == 0
    assert np.isfinite(record["subject_angle_isb"]).all()
    assert np.isnan(record["robot_rate"]).all()
    np.testing.assert_array_equal(record["torque_applied"], 0.0)


@pytest.mark.parametrize("compiled", [False, True], ids=["interpreted", "compiled"])
def test_a_trial_on_a_force_estimate_judges_the_estimate_not_the_sensor(compiled):
    """TrialParameters.force_estimate (EMG in place of the force sensor, chapter 5): the
    cone test takes the estimate the console sets between ticks; the sensor's reading is
    still recorded as it is; an estimate that stops coming is dropped after its limit."""
    from core.control.assistance import ESTIMATE_MAX_AGE_S

    params = PARAMS.replace(force_estimate="emg-model")
    plan = TrialPlan.build(params)
    sim = SimulatorBackend.from_trial(params, "passive", seed=2, compiled=compiled)
    sim.open()
    pipeline = TickPipeline(plan, compiled=compiled)
    reading = sim.read(0.0)
    pipeline.begin(reading.q1_rad, reading.q2_rad)
    active, forces = [], []
    stale = round(ESTIMATE_MAX_AGE_S / plan.period_s)
    for k in range(61 + stale):
        if k:
            reading = sim.read(k * plan.period_s)
        if k < 60:
            # 5 N along the path where the reference is: the passive arm does not push
            dx, dy = pipeline.reference_rows[min(k, len(pipeline.reference_rows) - 1)][4:6]
            pipeline.set_force_estimate(5.0 * dx, 5.0 * dy, k)
        tau = pipeline.control(k, reading)
        sim.write(*tau)
        record = pipeline.record(k, reading, k * 0.002, 0.0, 0.0, tau, 3, 0)
        active.append(pipeline.last_tick is not None and record[flat_names().index(
            "assistance_active")])
        forces.append(record[flat_names().index("force_sensor[0]")])
    sim.close()
    assert all(active[1:60])  # judged by the estimate: inside the cone
    assert active[59 + stale]  # the last estimate at its age limit still counts
    assert not active[60 + stale]  # one tick older: no push at all
    # the sensor's reading is what the record keeps
    assert max(abs(f) for f in forces) < 1.0
