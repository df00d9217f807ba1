"""Outside the exercise area between trials is a state, not a fault (docs/safety.md, H8).

The real robot's homing pose (120°/30° in the example settings) puts the handle at
(8.1, 48) cm, outside most exercises' areas, and every Connect latched WORKSPACE before
the therapist had touched anything: a daily fault to clear, which teaches clearing faults
blindly. With no trial the loop writes zero torque to a backdrivable robot, which cannot
drive the handle anywhere; the hazard is the handle driven out. So: between trials a
handle outside the area is said and holds Start; during a trial leaving it latches
WORKSPACE in the tick, as before; a joint beyond its limit or the links folding latch
always (the position itself is then suspect)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from core.robot import RobotModel
from core.trajectory import d_shape
from core.trial import THESIS_SUBJECT
from device.backend import SensorReading
from device.loop.engine import TickEngine
from device.loop.messages import (
    BackendConfig,
    Build,
    Connect,
    FaultRaised,
    HandleArea,
    Reply,
    Start,
)
from device.loop.process import AREA_CHECK_TICKS
from device.loop.states import State
from device.recording.messages import TrialEvent
from device.recording.trialfile.layout import SubjectInfo
from device.safety.faults import Fault
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor
from tests.device.bare_loop import bare_loop

ROBOT = RobotModel()
PERIOD = 0.002
LIMITS = SafetyLimits().around_path(d_shape((-0.30, 0.30), 0.10).points(), margin_m=0.10)
HOMING = (2.0943951, 0.5235988)  # resources/hardware.example.toml: 120°, 30°


def ticks(sup, q, n, *, driving, t0=0.0, torques=(0.0, 0.0), heartbeat=0.02, force=(0.0, 0.0)):
    """n ticks at pose q (a still handle): the faults each returned."""
    faults = []
    for k in range(n):
        t = t0 + (k + 1) * PERIOD
        out = sup.step(t, SensorReading(t, *q, *force, 5.0), 0.0, 0.0, *torques, 0.0,
                       heartbeat, False, False, driving=driving)
        faults.append(out[2])
    return faults


def within_limits(q1, q2):
    return not ROBOT.limit_problem(q1, q2)


@settings(max_examples=200, deadline=None)
@given(x=st.floats(-0.80, 0.80), y=st.floats(-0.10, 0.80))
def test_a_still_handle_between_trials_never_latches_workspace_wherever_hands_put_it(x, y):
    """Any reachable pose within the joint and spread limits, inside the area or not: no
    fault at zero torque with no trial, and the supervisor knows whether it is outside."""
    q1, q2 = (float(v) for v in ROBOT.ik_terms(x, y))
    if not (math.isfinite(q1) and math.isfinite(q2) and within_limits(q1, q2)):
        return
    sup = SafetySupervisor(ROBOT, LIMITS)
    assert ticks(sup, (q1, q2), 20, driving=False) == [Fault.NONE] * 20
    px, py = (float(v) for v in ROBOT.position(q1, q2))
    reach_min, reach_max = sup.reach_band_m
    x0, x1, y0, y1 = LIMITS.region_m
    outside = (not reach_min <= math.hypot(px, py) <= reach_max
               or not (x0 <= px <= x1 and y0 <= py <= y1))
    assert sup.outside_area == outside
    line = sup.outside_line(q1, q2)
    assert bool(line) == outside
    if outside:
        assert line.startswith("handle outside the ")
        assert ": guide it inside (now " in line


def test_the_homing_pose_of_the_example_settings_is_a_state_with_its_position():
    sup = SafetySupervisor(ROBOT, LIMITS)
    assert ticks(sup, HOMING, 50, driving=False) == [Fault.NONE] * 50
    x0, x1, y0, y1 = (f"{round(v * 100, 1):g}" for v in LIMITS.region_m)
    assert sup.outside_line(*HOMING) == (
        "handle outside the exercise area: guide it inside (now at 8.1, 48 cm; the area is "
        f"x {x0} to {x1} cm, y {y0} to {y1} cm)")
    # the same pose while a trial drives the handle: the fault, in the first tick
    driven = SafetySupervisor(ROBOT, LIMITS)
    assert ticks(driven, HOMING, 1, driving=True, torques=(0.3, 0.2)) == [Fault.WORKSPACE]


def test_the_other_checks_still_latch_while_the_handle_is_outside_between_trials():
    """The area no longer ends the checks' chain between trials: a check after it in the
    order (here the heartbeat) still latches."""
    sup = SafetySupervisor(ROBOT, LIMITS)
    ticks(sup, HOMING, 10, driving=False)
    assert ticks(sup, HOMING, 1, driving=False, t0=0.02, heartbeat=0.6) == [
        Fault.HEARTBEAT_LOST]


@pytest.mark.parametrize(("q", "problem"), [
    ((-0.0005, math.radians(-40.0)), "joint 1 is at"),
    ((math.radians(100.0), math.radians(90.0)), "the robot's links are"),
])
def test_a_joint_limit_or_folded_links_latch_even_between_trials(q, problem):
    """...and the banner says what the robot's angles are, not what a planned point's
    "would be", nor the form's "Move the point" (the banner's action says what to do)."""
    sup = SafetySupervisor(ROBOT, LIMITS)
    assert ticks(sup, q, 1, driving=False) == [Fault.WORKSPACE]
    assert problem in sup.fault_detail["problem"]
    assert "would be" not in sup.fault_message
    assert "Move the point" not in sup.fault_message
    assert sup.fault_message.count("exercise area") <= 1


def ik(x, y):
    return tuple(float(v) for v in ROBOT.ik_terms(x, y))


def test_a_driven_handle_leaving_the_area_latches_in_the_tick_it_leaves():
    sup = SafetySupervisor(ROBOT, LIMITS)
    x_max = LIMITS.region_m[1]
    t = 0.0
    for k, x in enumerate(np.arange(x_max - 0.010, x_max + 0.003, 0.001)):
        t += PERIOD
        out = sup.step(t, SensorReading(t, *ik(float(x), 0.30), 0.0, 0.0, 5.0), 0.0, 0.0,
                       0.3, 0.2, 0.0, 0.02, False, False, driving=True)
        if x <= x_max:
            assert out[2] is Fault.NONE, (k, x)
        else:
            assert out == (0.0, 0.0, Fault.WORKSPACE)
            break
    assert sup.fault_detail["problem"].startswith(f"it is at ({round(x * 100, 1):g}, 30) cm")


# ------------------------------------------------------------------------------ the loop
class Hand:
    """The real robot's handle as a person moves it: the simulator's readings with the
    angles of the pose the test puts the handle in (its time stamps and forces kept)."""

    def __init__(self, inner):
        self.inner = inner
        self.q: tuple[float, float] | None = None

    def __getattr__(self, name):
        return getattr(self.inner, name)

    def read(self, now_s):
        reading = self.inner.read(now_s)
        if self.q is None:
            return reading
        return reading._replace(q1_rad=self.q[0], q2_rad=self.q[1])

    def toward(self, x, y, step_m=0.001):
        """The poses of a hand moving the handle to (x, y) at 1 mm a tick (0.5 m/s)."""
        now = ROBOT.position(*(self.q or (self.inner.reading.q1_rad,
                                          self.inner.reading.q2_rad)))
        start = np.array([float(v) for v in now])
        end = np.array([x, y])
        n = max(1, int(np.ceil(np.linalg.norm(end - start) / step_m)))
        return [ik(*(start + (end - start) * (i + 1) / n)) for i in range(n)]


@pytest.fixture
def loop():
    with bare_loop(1 << 15) as (loop, _console):
        loop.said, loop.recorded = [], []
        loop._send = loop.said.append
        loop._to_recorder = loop.recorded.append
        loop._command(Build(1, THESIS_SUBJECT.replace(repetitions=1), BackendConfig(seed=3)))
        loop._command(Connect(2))
        loop.backend = hand = Hand(loop.backend)
        loop.engine = TickEngine(hand, loop.pipeline, loop.supervisor)
        loop.t0 = loop.clock.now()
        loop._beat = (0, loop.t0)
        loop.k = 0
        yield loop


def tick(loop, n=1, poses=None):
    """n ticks (or one per pose, the hand moving the handle through them), with the loop's
    heartbeat fresh: the tick's record for each."""
    cursor = loop.ring.write_count
    for q in poses or [None] * n:
        if q is not None:
            loop.backend.q = q
        loop.heartbeat.value += 1
        loop._tick(loop.k, loop.t0 + loop.k * PERIOD, 0.0)
        loop.k += 1
    return loop.ring.read_new(cursor).records


def test_between_trials_the_loop_says_where_the_handle_is_and_refuses_start_outside(loop):
    tick(loop)
    assert loop.state == State.CONNECTED
    region = loop.supervisor.limits.region_m
    outside_x, y = region[1] + 0.03, (region[2] + region[3]) / 2
    records = tick(loop, poses=loop.backend.toward(outside_x, y))
    records = np.concatenate([records, tick(loop, AREA_CHECK_TICKS)])
    assert loop.state == State.CONNECTED  # not faulted: a person moved it, at zero torque
    assert not records["fault"].any()
    assert (records["torque_applied"] == 0.0).all()
    lines = [m.line for m in loop.said if isinstance(m, HandleArea)]
    assert lines
    assert lines[-1].startswith("handle outside the exercise area: guide it inside (now at "
                                f"{round(outside_x * 100, 1):g}, ")
    loop._command(Start(3, "/tmp/outside.h5", SubjectInfo("P1", 70.0, 0.3, 0.3, "right")))
    reply = [m for m in loop.said if isinstance(m, Reply)][-1]
    assert not reply.ok
    assert reply.message == f"start refused: {lines[-1]}."
    assert "\n" not in reply.message
    assert loop.state == State.CONNECTED
    # guided back inside: said, and Start goes
    inside_x = region[1] - 0.05
    tick(loop, poses=loop.backend.toward(inside_x, y))
    tick(loop, AREA_CHECK_TICKS)
    assert [m.line for m in loop.said if isinstance(m, HandleArea)][-1] == ""
    loop._command(Start(4, "/tmp/inside.h5", SubjectInfo("P1", 70.0, 0.3, 0.3, "right")))
    assert loop.state == State.RUNNING


def test_a_trial_that_drives_the_handle_out_latches_in_the_tick_and_its_record_says_so(loop):
    tick(loop, 5)
    loop._command(Start(3, "/tmp/trial.h5", SubjectInfo("P1", 70.0, 0.3, 0.3, "right")))
    assert loop.state == State.RUNNING
    region = loop.supervisor.limits.region_m
    for q in loop.backend.toward(region[1] + 0.003, region[3] - 0.1):
        record = tick(loop, poses=[q])[-1]
        outside = float(ROBOT.position(*q)[0]) > region[1]
        if not outside:
            assert loop.state == State.RUNNING
            assert record["fault"] == 0
            continue
        # the first tick outside: latched, zero torque written, and in the record
        assert loop.state == State.FAULTED
        assert record["fault"] == int(Fault.WORKSPACE)
        assert (record["torque_applied"] == 0.0).all()
        break
    else:
        raise AssertionError("the hand never left the area")
    events = [m for m in loop.recorded if isinstance(m, TrialEvent) and m.kind == "fault"]
    assert len(events) == 1
    assert events[0].values["fault"] == "workspace"
    assert "outside the exercise area" in events[0].values["problem"]
    assert any(isinstance(m, FaultRaised) and m.code == int(Fault.WORKSPACE)
               for m in loop.said)
