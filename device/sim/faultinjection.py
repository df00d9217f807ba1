"""Fault injection: make any backend misbehave on cue, to prove the supervisor and the loop react.

`FaultInjectingBackend(inner, scenario, at_s)` speaks the Backend protocol and
passes everything through to `inner` until the loop time reaches `at_s`; from
the first read at or after `at_s` it injects one scenario for `duration_s`
(its default depends on the scenario; at least one read is always affected):

=================  ==========================================  ==========================
scenario           what the loop sees                          fault it must latch
=================  ==========================================  ==========================
stale              the same reading (time stamp included)      SENSOR_STALE
                   again and again, as from a stuck DAQ buffer
encoder_jump       q1 offset by `jump_rad` from then on, as    ENCODER_JUMP
                   after lost counts (the offset stays)
force_spike        `force_N` added to the sensor's x' force    FORCE_LIMIT
nan                one field of the reading is NaN             NOT_FINITE
exception          read raises BackendError                    BACKEND_ERROR
hang               read blocks up to `block_s`, then raises    BACKEND_TIMEOUT
                   BackendTimeout (the device stopped
                   answering); the next tick is late too
late               one read sleeps `sleep_s`, then answers     LATE_TICK (from the
                   normally                                    loop's lateness, on a
                                                               REAL_TIME backend)
stalls             one read every `every_s` sleeps `sleep_s`,  LATE_TICK on a REAL_TIME
                   as the host's stalls of a shared machine    backend; none on the
                   do (a session with late ticks throughout)   simulator
workspace_exit     q1 driven at `rate_rad_s` (slow enough not  WORKSPACE
                   to be overspeed) until the links fold
overspeed          q1 driven at `rate_rad_s` (above the        JOINT_SPEED
                   speed limit, below an encoder jump)
=================  ==========================================  ==========================

`EXPECTED_FAULT` maps each scenario to that code, for the loop's tests. The wrapper
runs on its inner backend's clock (`timing`): a `late` read on the simulator is
measured and recorded but faults nothing (device.backend), so a test of the
watchdog wraps a simulator built with REAL_TIME timing, as hardware is.

The hang never blocks a test forever: each read waits at most `block_s` on an
event, and `release()` (or `close()`) wakes it at once, so a loop test can
watch its watchdog see the stalled read and then end.

Loop-level scenarios
--------------------
A lost heartbeat, an e-stop and a stalled recorder are not the backend's doing,
so `LoopFaultInjection` schedules them instead: the loop test passes what its
own bookkeeping measured through the injection before handing it to the
supervisor,

    age = injection.heartbeat_age_s(now_s, measured_age_s)
    estop = injection.estop(now_s, estop_held)
    lost = injection.recording_lost(now_s, ring_overrun)

which leaves the real values untouched outside the scenario's window. An
end-to-end test should in addition make the real cause happen once: stop
sending heartbeats from the test's console client, press the client's e-stop,
and stop draining the ring for longer than it holds.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass

from core.errors import ParameterError, check_non_negative, check_positive, check_range
from device.backend import Backend, SensorReading
from device.errors import BackendError, BackendTimeout
from device.safety.faults import Fault

EXPECTED_FAULT: dict[str, Fault] = {
    "stale": Fault.SENSOR_STALE,
    "encoder_jump": Fault.ENCODER_JUMP,
    "force_spike": Fault.FORCE_LIMIT,
    "nan": Fault.NOT_FINITE,
    "exception": Fault.BACKEND_ERROR,
    "hang": Fault.BACKEND_TIMEOUT,
    "late": Fault.LATE_TICK,
    "stalls": Fault.LATE_TICK,
    "workspace_exit": Fault.WORKSPACE,
    "overspeed": Fault.JOINT_SPEED,
}
SCENARIOS = tuple(EXPECTED_FAULT)

# How long each scenario lasts by default: a fault that stays (a dead device, a
# frozen buffer, lost encoder counts, a runaway) or a glitch of one read.
_DEFAULT_DURATION_S = {
    "stale": math.inf,
    "encoder_jump": math.inf,
    "force_spike": 0.02,
    "nan": 0.0,
    "exception": 0.0,
    "hang": math.inf,
    "late": 0.0,
    "stalls": math.inf,
    "workspace_exit": math.inf,
    "overspeed": math.inf,
}
_DEFAULT_RATE_RAD_S = {"workspace_exit": 1.0, "overspeed": 8.0}

LOOP_SCENARIOS: dict[str, Fault] = {
    "heartbeat_lost": Fault.HEARTBEAT_LOST,
    "estop": Fault.ESTOP,
    "recorder_stalled": Fault.RECORDING_LOST,
}


class FaultInjectingBackend:
    """Wraps `inner` (any Backend) and injects `scenario` from loop time `at_s` on.

    Parameters used by one scenario only (units in the names):
    jump_rad (encoder_jump, default 0.5 rad), force_N (force_spike, 100 N: past the
    default 50 N limit, inside the sensor's range), field (nan: a SensorReading
    field, default 'q1_rad'), sleep_s (late, 0.015 s), block_s (hang, 0.1 s per
    read), rate_rad_s (workspace_exit 1.0 rad/s, overspeed 8.0 rad/s), every_s
    (stalls, 1.0 s of loop time between stalls).
    """

    def __init__(
        self,
        inner: Backend,
        scenario: str,
        at_s: float,
        *,
        duration_s: float | None = None,
        jump_rad: float = 0.5,
        force_N: float = 100.0,
        field: str = "q1_rad",
        sleep_s: float = 0.015,
        block_s: float = 0.1,
        rate_rad_s: float | None = None,
        every_s: float = 1.0,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        if scenario not in EXPECTED_FAULT:
            raise ParameterError("scenario", scenario, ", ".join(SCENARIOS))
        check_non_negative("at_s", at_s, "s", "loop time at which the fault starts")
        if duration_s is None:
            duration_s = _DEFAULT_DURATION_S[scenario]
        elif duration_s != math.inf:
            check_non_negative("duration_s", duration_s, "s",
                               "0 affects one read only; inf lasts until closed")
        if field not in SensorReading._fields:
            raise ParameterError("field", field, ", ".join(SensorReading._fields))
        check_range("jump_rad", jump_rad, -math.pi, math.pi, "rad", "an encoder offset")
        check_positive("sleep_s", sleep_s, "s")
        check_range("block_s", block_s, 0.0, 60.0, "s",
                    "a hung read must end so that a test cannot hang", low_open=True)
        if rate_rad_s is None:
            rate_rad_s = _DEFAULT_RATE_RAD_S.get(scenario, 1.0)
        check_range("rate_rad_s", rate_rad_s, -50.0, 50.0, "rad/s",
                    "a ramp on joint 1; above 50 rad/s it would be an encoder jump")
        check_range("force_N", force_N, -1000.0, 1000.0, "N")
        check_positive("every_s", every_s, "s")
        self.inner = inner
        self.name = f"{inner.name}+{scenario}"
        self.timing = inner.timing
        self.scenario = scenario
        self.at_s = float(at_s)
        self.duration_s = float(duration_s)
        self.jump_rad = float(jump_rad)
        self.force_N = float(force_N)
        self.field = field
        self.sleep_s = float(sleep_s)
        self.block_s = float(block_s)
        self.rate_rad_s = float(rate_rad_s)
        self.every_s = float(every_s)
        self._next_stall_s = self.at_s
        self._sleep = sleep
        self._fired_at_s: float | None = None
        self._frozen: SensorReading | None = None
        self._release = threading.Event()

    @property
    def expected_fault(self) -> Fault:
        """The fault the supervisor must latch for this scenario."""
        return EXPECTED_FAULT[self.scenario]

    @property
    def fired_at_s(self) -> float | None:
        """Loop time of the first read the scenario affected; None before."""
        return self._fired_at_s

    def active(self, now_s: float) -> bool:
        """Whether a read at `now_s` is affected (at least the first at or after at_s)."""
        if now_s < self.at_s:
            return False
        if self._fired_at_s is None:
            return True
        return now_s < self._fired_at_s + self.duration_s

    def release(self) -> None:
        """Wake a hung read at once; later hung reads raise without waiting."""
        self._release.set()

    # ------------------------------------------------------------ protocol
    def open(self) -> None:
        self.inner.open()

    def read(self, now_s: float) -> SensorReading:
        if not self.active(now_s):
            return self.inner.read(now_s)
        if self._fired_at_s is None:
            self._fired_at_s = now_s
        scenario = self.scenario
        if scenario == "hang":
            self._release.wait(self.block_s)
            raise BackendTimeout(
                f"injected: {self.inner.name} did not answer within {self.block_s:g} s"
            )
        if scenario == "exception":
            raise BackendError(f"injected: {self.inner.name} read failed")
        if scenario == "late":
            self._sleep(self.sleep_s)
            return self.inner.read(now_s)
        if scenario == "stalls":
            if now_s >= self._next_stall_s:
                self._next_stall_s = now_s + self.every_s
                self._sleep(self.sleep_s)
            return self.inner.read(now_s)
        reading = self.inner.read(now_s)
        if scenario == "stale":
            if self._frozen is None:
                self._frozen = reading
            return self._frozen
        if scenario == "nan":
            return reading._replace(**{self.field: math.nan})
        if scenario == "force_spike":
            return reading._replace(force_x_N=reading.force_x_N + self.force_N)
        if scenario == "encoder_jump":
            return reading._replace(q1_rad=reading.q1_rad + self.jump_rad)
        # workspace_exit, overspeed: joint 1 driven away from where the robot really is.
        offset = self.rate_rad_s * (now_s - self._fired_at_s)
        return reading._replace(q1_rad=reading.q1_rad + offset)

    def write(self, torque1_Nm: float, torque2_Nm: float) -> None:
        self.inner.write(torque1_Nm, torque2_Nm)

    def cue_patient(self, at_s: float | None = None) -> None:
        """The simulator's virtual patient starts the exercise with the reference, as it
        does without the injector. Without this the loop found no cue on the wrapper and
        the patient held the path's start all trial while the robot drove the D: every
        injected fault fell on a robot pushing at its clamp against the arm, which a
        lasting clamp's fault (TORQUE_SATURATED) then caught before the injected one."""
        cue = getattr(self.inner, "cue_patient", None)
        if cue is not None:
            cue(at_s)

    def rest_patient(self) -> None:
        """The simulator's virtual patient rests after the trial, as without the injector."""
        rest = getattr(self.inner, "rest_patient", None)
        if rest is not None:
            rest()

    def safe_state(self) -> None:
        self.inner.safe_state()

    def close(self) -> None:
        self._release.set()
        self.inner.close()


@dataclass(frozen=True, slots=True)
class LoopFaultInjection:
    """A loop-level fault (heartbeat_lost, estop, recorder_stalled) scheduled at `at_s`
    for `duration_s`; each method returns the real value outside that window."""

    scenario: str
    at_s: float
    duration_s: float = math.inf

    def __post_init__(self) -> None:
        if self.scenario not in LOOP_SCENARIOS:
            raise ParameterError("scenario", self.scenario, ", ".join(LOOP_SCENARIOS))
        check_non_negative("at_s", self.at_s, "s")
        if self.duration_s != math.inf:
            check_non_negative("duration_s", self.duration_s, "s")

    @property
    def expected_fault(self) -> Fault:
        return LOOP_SCENARIOS[self.scenario]

    def active(self, now_s: float) -> bool:
        return self.at_s <= now_s <= self.at_s + self.duration_s

    def heartbeat_age_s(self, now_s: float, age_s: float) -> float:
        """The console goes silent at at_s: the age grows from then on."""
        if self.scenario == "heartbeat_lost" and self.active(now_s):
            return max(age_s, now_s - self.at_s)
        return age_s

    def estop(self, now_s: float, held: bool) -> bool:
        return held or (self.scenario == "estop" and self.active(now_s))

    def recording_lost(self, now_s: float, lost: bool) -> bool:
        return lost or (self.scenario == "recorder_stalled" and self.active(now_s))
