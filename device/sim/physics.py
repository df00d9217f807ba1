"""The simulator's physics as kernels: the coupled robot and arm with the patient's torque
(eq. 3.6, 3.20, 3.27–3.33), the integrator, the sensors, and a read and a write.

device.sim.simulator's module notes explain the model and the integrators;
`SimulatorBackend` builds the vectors below and runs these kernels, compiled for a
VirtualPatient (whose torque, device.sim.patients.patient_torque, is a kernel too) and
interpreted for any other object of the Patient protocol (a flavour in which
`patient_torque` calls the object's own `torque`; core.kernels). The loop's tick engine
and the headless run call the same kernels on the same vectors.

Vectors: `r` the robot's constants (core.robot_terms), `a` the arm's
(core.arm_terms), `p`, `table`, `episodes` the patient's (device.sim.patients), `c` the
sensors' and the integrator's (S_* below), `x` the simulator's state (X_*), `noise` the
sensor noise as rows of three standard normal numbers, `scratch` SCRATCH_SIZE floats.
"""

from __future__ import annotations

import math

from core.interaction import arm_state, coupled_motion
from core.kernels import kernel
from device.sim.patient_torque import patient_torque

# The sensors' and the integrator's constants (SimulatorBackend.constants).
(S_OFFSET, S_NOISE_XY, S_NOISE_Z, S_LOAD, S_RXY, S_RZ, S_LIMIT_XY, S_LIMIT_Z, S_CPR1,
 S_CPR2, S_STEP, S_RATE, S_MAX1, S_MAX2, S_RK4, S_DELAY, S_GAIN1, S_GAIN2, S_SIZE) = range(19)

# The state: steps taken, θ_R and θ̇_R, the torque held and the one of the last full
# evaluation, the patient's cue, the clock's anchor, whether the last evaluation may be
# reused, the next noise row, then the last evaluation (EVALUATION values) and the
# last reading (time, q1, q2, fx, fy, fz).
(X_STEPS, X_Q1, X_Q2, X_QD1, X_QD2, X_TAU1, X_TAU2, X_LAST_TAU1, X_LAST_TAU2, X_T0,
 X_ANCHORED, X_ANCHOR, X_CACHED, X_NOISE) = range(14)
X_LAST = 14
EVALUATION = 15
"""What `evaluate` writes: θ̈_R1, θ̈_R2, F_x, F_y, θ_s, θ_e, θ̇_s, θ̇_e, θ̈_s, θ̈_e, τ_s, τ_e
and the inverse coupled mass (n11, n12, n22)."""
X_READING = X_LAST + EVALUATION
X_PENDING = X_READING + 6
"""The command waiting for the drives when they are a tick late (S_DELAY)."""
X_SIZE = X_PENDING + 2

SCRATCH_SIZE = EVALUATION + 5
FAILED_AT = EVALUATION
"""Where a failed step leaves (t, q1, q2, qd1, qd2) in the scratch, for its message; a
sensor out of range leaves its three readings at the scratch's start."""

# Why a read failed; the simulator raises the matching exception.
OK, ARM_STRAIGHT, NOT_FINITE, SENSOR_RANGE, BAD_TIME = range(5)

_TWO_PI = 2.0 * math.pi


@kernel
def evaluate(r, a, p, table, episodes, t, q1, q2, qd1, qd2, tau1, tau2, out, into):
    """The coupled dynamics at patient time `t` with the patient's torque asked for at
    the arm's state: writes EVALUATION values into out[into:]; OK or ARM_STRAIGHT."""
    ok, ts, te, tsd, ted, rt, at = arm_state(r, a, q1, q2, qd1, qd2)
    if not ok:
        return ARM_STRAIGHT
    tau_s, tau_e = patient_torque(p, table, episodes, t, ts, te, tsd, ted)
    qdd1, qdd2, fx, fy, tsdd, tedd, n11, n12, n22 = coupled_motion(
        r, a, rt, at, q1, q2, qd1, qd2, tau1, tau2, tau_s, tau_e, tsd, ted)
    out[into] = qdd1
    out[into + 1] = qdd2
    out[into + 2] = fx
    out[into + 3] = fy
    out[into + 4] = ts
    out[into + 5] = te
    out[into + 6] = tsd
    out[into + 7] = ted
    out[into + 8] = tsdd
    out[into + 9] = tedd
    out[into + 10] = tau_s
    out[into + 11] = tau_e
    out[into + 12] = n11
    out[into + 13] = n12
    out[into + 14] = n22
    return OK


@kernel
def sample(c, x, steps, q1, q2, scratch, noise):
    """The sensors' reading of the evaluation in scratch[:EVALUATION] into x[X_READING:]:
    time, the encoders' quantised angles (core.motor), the force sensor's noisy and
    quantised reading in its own frame (device.sim.sensors, eq. 3.35–3.36 inverted).
    Uses the next noise row; SENSOR_RANGE (the readings left in scratch[0:3]) when
    the force is beyond the sensor's range, and then nothing is written."""
    fx = scratch[2]
    fy = scratch[3]
    row = noise[int(x[X_NOISE])]
    x[X_NOISE] += 1.0
    rxy = c[S_RXY]
    rz = c[S_RZ]
    # the sensor turns with link 4 (θ_R1) plus its mounting angle
    angle = q1 + c[S_OFFSET]
    co = math.cos(angle)
    si = math.sin(angle)
    # noise on the analogue signal, then the ADC's quantisation
    fxs = math.floor((co * fx + si * fy + c[S_NOISE_XY] * row[0]) / rxy + 0.5) * rxy
    fys = math.floor((co * fy - si * fx + c[S_NOISE_XY] * row[1]) / rxy + 0.5) * rxy
    fzs = math.floor((c[S_LOAD] + c[S_NOISE_Z] * row[2]) / rz + 0.5) * rz
    lxy = c[S_LIMIT_XY]
    lz = c[S_LIMIT_Z]
    if not (-lxy <= fxs <= lxy and -lxy <= fys <= lxy and -lz <= fzs <= lz):
        scratch[0] = fxs
        scratch[1] = fys
        scratch[2] = fzs
        return SENSOR_RANGE
    cpr1 = c[S_CPR1]
    cpr2 = c[S_CPR2]
    x[X_READING] = steps * c[S_STEP]
    x[X_READING + 1] = round(q1 * cpr1 / _TWO_PI) * 2.0 * math.pi / cpr1
    x[X_READING + 2] = round(q2 * cpr2 / _TWO_PI) * 2.0 * math.pi / cpr2
    x[X_READING + 3] = fxs
    x[X_READING + 4] = fys
    x[X_READING + 5] = fzs
    return OK


@kernel
def last_reading(x):
    """The reading `sample` left in x: (time, q1, q2, fx, fy, fz), as a backend's `read`
    gives it (device.backend.SensorReading's order)."""
    return (x[X_READING], x[X_READING + 1], x[X_READING + 2], x[X_READING + 3],
            x[X_READING + 4], x[X_READING + 5])


@kernel
def _failed_at(scratch, t, q1, q2, qd1, qd2):
    scratch[FAILED_AT] = t
    scratch[FAILED_AT + 1] = q1
    scratch[FAILED_AT + 2] = q2
    scratch[FAILED_AT + 3] = qd1
    scratch[FAILED_AT + 4] = qd2


@kernel
def advance(r, a, c, p, table, episodes, x, n, noise, scratch):
    """`n` integrator steps with the torque held, then a full evaluation and a sample.
    A failure commits nothing (the simulator stays at its last, sound reading) and
    leaves where it failed in the scratch."""
    tau1 = x[X_TAU1]
    tau2 = x[X_TAU2]
    h = c[S_STEP]
    t0 = x[X_T0]
    q1 = x[X_Q1]
    q2 = x[X_Q2]
    qd1 = x[X_QD1]
    qd2 = x[X_QD2]
    steps = int(x[X_STEPS])
    rk4 = c[S_RK4] != 0.0
    t = steps * h - t0  # the patient's time: from their cue to start
    for i in range(n):
        if i == 0 and x[X_CACHED] != 0.0:
            # The last reading's accelerations, with the torque change through the
            # inverse coupled mass: they are affine in τ_R.
            dt1 = tau1 - x[X_LAST_TAU1]
            dt2 = tau2 - x[X_LAST_TAU2]
            a1 = x[X_LAST] + x[X_LAST + 12] * dt1 + x[X_LAST + 13] * dt2
            a2 = x[X_LAST + 1] + x[X_LAST + 13] * dt1 + x[X_LAST + 14] * dt2
        else:
            status = evaluate(r, a, p, table, episodes, t, q1, q2, qd1, qd2, tau1, tau2,
                              scratch, 0)
            if status != OK:
                _failed_at(scratch, t + t0, q1, q2, qd1, qd2)
                return status
            a1 = scratch[0]
            a2 = scratch[1]
        if rk4:
            hh = 0.5 * h
            tm = t + hh
            v1b = qd1 + hh * a1
            v2b = qd2 + hh * a2
            status = evaluate(r, a, p, table, episodes, tm, q1 + hh * qd1, q2 + hh * qd2,
                              v1b, v2b, tau1, tau2, scratch, 0)
            if status != OK:
                _failed_at(scratch, t + t0, q1, q2, qd1, qd2)
                return status
            b1 = scratch[0]
            b2 = scratch[1]
            v1c = qd1 + hh * b1
            v2c = qd2 + hh * b2
            status = evaluate(r, a, p, table, episodes, tm, q1 + hh * v1b, q2 + hh * v2b,
                              v1c, v2c, tau1, tau2, scratch, 0)
            if status != OK:
                _failed_at(scratch, t + t0, q1, q2, qd1, qd2)
                return status
            c1 = scratch[0]
            c2 = scratch[1]
            v1d = qd1 + h * c1
            v2d = qd2 + h * c2
            status = evaluate(r, a, p, table, episodes, t + h, q1 + h * v1c, q2 + h * v2c,
                              v1d, v2d, tau1, tau2, scratch, 0)
            if status != OK:
                _failed_at(scratch, t + t0, q1, q2, qd1, qd2)
                return status
            d1 = scratch[0]
            d2 = scratch[1]
            h6 = h / 6.0
            q1 += h6 * (qd1 + 2.0 * (v1b + v1c) + v1d)
            q2 += h6 * (qd2 + 2.0 * (v2b + v2c) + v2d)
            qd1 += h6 * (a1 + 2.0 * (b1 + c1) + d1)
            qd2 += h6 * (a2 + 2.0 * (b2 + c2) + d2)
        else:
            # semi-implicit (symplectic) Euler
            qd1 += h * a1
            qd2 += h * a2
            q1 += h * qd1
            q2 += h * qd2
        steps += 1
        t = steps * h - t0
        if not math.isfinite(q1 + q2 + qd1 + qd2):
            _failed_at(scratch, t + t0, q1, q2, qd1, qd2)
            return NOT_FINITE
    status = evaluate(r, a, p, table, episodes, t, q1, q2, qd1, qd2, tau1, tau2, scratch, 0)
    if status != OK:
        _failed_at(scratch, t + t0, q1, q2, qd1, qd2)
        return status
    for j in range(EVALUATION):
        if not math.isfinite(scratch[j]):
            _failed_at(scratch, t + t0, q1, q2, qd1, qd2)
            return NOT_FINITE
    status = sample(c, x, steps, q1, q2, scratch, noise)
    if status != OK:
        return status
    for j in range(EVALUATION):
        x[X_LAST + j] = scratch[j]
    x[X_Q1] = q1
    x[X_Q2] = q2
    x[X_QD1] = qd1
    x[X_QD2] = qd2
    x[X_STEPS] = steps
    x[X_LAST_TAU1] = tau1
    x[X_LAST_TAU2] = tau2
    x[X_CACHED] = 1.0
    return OK


@kernel
def read(r, a, c, p, table, episodes, x, now_s, noise, scratch):
    """Advance in whole steps while a step fits before `now_s` and sample: the clock is
    anchored at the first read, so the first reading is the initial state at simulated
    time 0 whatever clock the caller uses. BAD_TIME for a non-finite `now_s`."""
    if x[X_ANCHORED] == 0.0:
        if not math.isfinite(now_s):
            return BAD_TIME
        x[X_ANCHOR] = now_s
        x[X_ANCHORED] = 1.0
    # whole steps that fit before now_s (a hair of tolerance for k·0.002 round-off)
    ahead = (now_s - x[X_ANCHOR]) * c[S_RATE] - x[X_STEPS] + 1e-7
    if ahead >= 1.0 and ahead != math.inf:
        return advance(r, a, c, p, table, episodes, x, int(ahead), noise, scratch)
    if not ahead < 1.0:
        return BAD_TIME
    return OK


@kernel
def write(c, x, tau1, tau2):
    """Hold a torque command; the drives saturate at the motors' limit, give the torque
    times their gain (1 on the ideal plant; device.sim.plant), and, when S_DELAY is set,
    apply the command one write later (the amplifier's and the transport's delay)."""
    m1 = c[S_MAX1]
    m2 = c[S_MAX2]
    tau1 = c[S_GAIN1] * (m1 if tau1 > m1 else -m1 if tau1 < -m1 else tau1)
    tau2 = c[S_GAIN2] * (m2 if tau2 > m2 else -m2 if tau2 < -m2 else tau2)
    if c[S_DELAY] != 0.0:
        held1 = x[X_PENDING]
        held2 = x[X_PENDING + 1]
        x[X_PENDING] = tau1
        x[X_PENDING + 1] = tau2
        tau1 = held1
        tau2 = held2
    x[X_TAU1] = tau1
    x[X_TAU2] = tau2


@kernel
def reset(r, a, c, p, table, episodes, q1, q2, t0, x, noise, scratch):
    """At rest at (q1, q2) with zero torque, the patient's clock at −t0, the clock not
    anchored, the first sample taken with the next noise row: OK, or why not."""
    start = x[X_NOISE]
    for j in range(X_SIZE):
        x[j] = 0.0
    x[X_Q1] = q1
    x[X_Q2] = q2
    x[X_T0] = t0
    x[X_NOISE] = start
    status = evaluate(r, a, p, table, episodes, -t0, q1, q2, 0.0, 0.0, 0.0, 0.0, scratch, 0)
    if status != OK:
        _failed_at(scratch, 0.0, q1, q2, 0.0, 0.0)
        return status
    for j in range(EVALUATION):
        x[X_LAST + j] = scratch[j]
    x[X_CACHED] = 1.0
    return sample(c, x, int(x[X_STEPS]), q1, q2, scratch, noise)
