"""Each per-tick formula is one function: compiled by numba it gives what it gives run by
Python, bit for bit (not a compiled twin against a Python twin). And the flavours that
run the kernels are sound: numpy arrays element by element, replacements where asked,
and a kernel that would escape its flavour is refused."""

import math

import numpy as np
import pytest

from core import arm_terms, robot_terms
from core.control.assistance import assisted_torques
from core.control.ctpid import ctpid_torques
from core.control.smc import smc_torques
from core.control.transparent import TransparentGains, transparent_torques
from core.interaction import arm_state, coupled_motion
from core.kernels import ARRAYS, Flavour, interpreted, kernel
from core.robot import Friction, RobotModel, Stiffness
from core.signal import RateEstimator, track
from core.trial import THESIS_SUBJECT
from device.compiled.jit import compiled
from device.loop.pipeline import TickPipeline, TrialPlan
from device.safety import checks
from device.safety.limits import SafetyLimits
from device.safety.supervisor import SafetySupervisor
from device.sim.patient_parameters import PATIENT_KINDS
from device.sim.patient_torque import patient_torque
from device.sim.patients import make_patient

ROBOT = RobotModel(
    friction=Friction((0.05, 0.04), (0.02, 0.03), ee_coulomb_N=0.3, ee_viscous_Ns_m=0.5),
    stiffness=Stiffness(0.5, 0.1, 0.4, 1.0, 2.0),
)
"""Every term of eq. 3.6 on, so every branch of the robot's kernels runs."""
ARM = THESIS_SUBJECT.arm()
R = np.asarray(ROBOT.constants)
A = np.asarray(ARM.constants)


def poses(n=200, seed=1):
    """Joint angles on the robot's working branch over the thesis's table, with rates,
    accelerations, torques and forces of the size a trial sees."""
    rng = np.random.default_rng(seed)
    points = rng.uniform([-0.40, 0.20], [-0.15, 0.45], (n, 2))
    q = ROBOT.ik(points)
    return [(float(q1), float(q2), *map(float, rng.normal(0.0, [1.0, 1.0, 5.0, 5.0, 1.0, 1.0,
                                                                  3.0, 3.0])))
            for q1, q2 in q]


def same(a, b):
    """Equal to the bit (NaN equal to NaN), element by element for tuples."""
    if isinstance(a, tuple):
        return len(a) == len(b) and all(same(x, y) for x, y in zip(a, b, strict=True))
    if isinstance(a, float) and math.isnan(a):
        return math.isnan(b)
    return a == b and type(a is True) is type(b is True)


ROBOT_KERNELS = [
    (robot_terms.position, lambda q1, q2, *_: (q1, q2)),
    (robot_terms.jacobian_terms, lambda q1, q2, *_: (q1, q2)),
    (robot_terms.jacobian_dot_terms, lambda q1, q2, v1, v2, *_: (q1, q2, v1, v2)),
    (robot_terms.mass_terms, lambda q1, q2, *_: (q1, q2)),
    (robot_terms.coriolis_terms, lambda q1, q2, v1, v2, *_: (q1, q2, v1, v2)),
    (robot_terms.friction_terms, lambda q1, q2, v1, v2, *_: (q1, q2, v1, v2)),
    (robot_terms.stiffness_terms, lambda q1, q2, *_: (q1, q2)),
    (robot_terms.bias_terms, lambda q1, q2, v1, v2, *_: (q1, q2, v1, v2)),
    (robot_terms.inverse_dynamics_terms, lambda q1, q2, v1, v2, a1, a2, t1, t2, f1, f2:
        (q1, q2, v1, v2, a1, a2, f1, f2)),
    (robot_terms.forward_dynamics_terms, lambda q1, q2, v1, v2, a1, a2, t1, t2, f1, f2:
        (q1, q2, v1, v2, t1, t2, f1, f2)),
    (robot_terms.joint_torque_terms, lambda q1, q2, v1, v2, a1, a2, t1, t2, f1, f2:
        (q1, q2, f1, f2)),
    (robot_terms.kinetic_energy_terms, lambda q1, q2, v1, v2, *_: (q1, q2, v1, v2)),
    (robot_terms.potential_energy_terms, lambda q1, q2, *_: (q1, q2)),
    (robot_terms.limit_violation, lambda q1, q2, *_: (q1, q2)),
]


@pytest.mark.parametrize(("function", "args"), ROBOT_KERNELS,
                         ids=[f.__name__ for f, _ in ROBOT_KERNELS])
def test_the_robots_formulas_compiled_are_the_interpreted_ones(function, args):
    fast = compiled(function)
    for pose in poses():
        assert same(fast(R, *args(*pose)), function(ROBOT.constants, *args(*pose)))


def test_the_robots_inverse_kinematics_compiled_is_the_interpreted_one():
    fast = compiled(robot_terms.ik_terms)
    for x, y in [(-0.3, 0.3), (-0.2, 0.41), (0.9, 0.9), (0.0, 0.0), (math.nan, 0.3)]:
        assert same(fast(R, x, y), robot_terms.ik_terms(ROBOT.constants, x, y))


ARM_KERNELS = [
    (arm_terms.position, 2), (arm_terms.elbow_position, 2), (arm_terms.jacobian_terms, 2),
    (arm_terms.jacobian_dot_terms, 4), (arm_terms.mass_terms, 2),
    (arm_terms.coriolis_terms, 4), (arm_terms.inverse_dynamics_terms, 8),
    (arm_terms.forward_dynamics_terms, 8), (arm_terms.kinetic_energy_terms, 4),
    (arm_terms.ik_terms, 2),
]


@pytest.mark.parametrize(("function", "n"), ARM_KERNELS, ids=[f.__name__ for f, _ in ARM_KERNELS])
def test_the_arms_formulas_compiled_are_the_interpreted_ones(function, n):
    fast = compiled(function)
    rng = np.random.default_rng(2)
    for _ in range(200):
        args = tuple(float(v) for v in rng.normal(0.0, 1.5, n))
        if function is arm_terms.ik_terms:
            args = (float(rng.uniform(-0.6, 0.1)), float(rng.uniform(0.1, 0.7)))
        assert same(fast(A, *args), function(ARM.constants, *args))


def test_the_coupled_dynamics_compiled_are_the_interpreted_ones():
    closure, motion = compiled(arm_state), compiled(coupled_motion)
    for q1, q2, v1, v2, _, _, t1, t2, f1, f2 in poses():
        state = arm_state(ROBOT.constants, ARM.constants, q1, q2, v1, v2)
        assert same(closure(R, A, q1, q2, v1, v2), state)
        ok, _, _, tsd, ted, rt, at = state
        if ok:
            args = (rt, at, q1, q2, v1, v2, t1, t2, f1, f2, tsd, ted)
            assert same(motion(R, A, *args), coupled_motion(ROBOT.constants, ARM.constants,
                                                            *args))


def test_the_controllers_and_the_assistance_compiled_are_the_interpreted_ones():
    plan = TrialPlan.build(THESIS_SUBJECT)
    smc = TickPipeline(plan).controller
    ctpid = TickPipeline(plan.__class__.build(THESIS_SUBJECT.replace(controller="ctpid"))
                         ).controller
    assist = TickPipeline(plan).assistance
    fast_smc, fast_ctpid, fast_assist = (compiled(f) for f in (smc_torques, ctpid_torques,
                                                               assisted_torques))
    state_fast, state_slow = np.zeros(4), [0.0] * 4
    for q1, q2, v1, v2, a1, a2, t1, t2, f1, f2 in poses():
        reference = (q1 + 0.01 * a1, q2 - 0.01 * a2, v1 + 0.1, v2, a1, a2)
        assert same(fast_smc(R, np.asarray(smc.constants), q1, q2, v1, v2, *reference),
                    smc_torques(ROBOT.constants, smc.constants, q1, q2, v1, v2, *reference))
        fast = fast_ctpid(R, np.asarray(ctpid.constants), state_fast, 0.002, q1, q2, v1, v2,
                          *reference)
        slow = ctpid_torques(ROBOT.constants, ctpid.constants, state_slow, 0.002, q1, q2, v1,
                             v2, *reference)
        assert same(fast, slow)
        assert state_fast.tolist() == state_slow
        for direction in ((1.0, 0.0), (f1, f2), (0.0, 0.0)):
            args = (q1, q2, t1, t2, f1, f2, *direction)
            assert same(fast_assist(R, np.asarray(assist.constants), *args),
                        assisted_torques(ROBOT.constants, assist.constants, *args))


@pytest.mark.parametrize("gains", [TransparentGains(), TransparentGains(0.9, 0.95, 1.0),
                                   TransparentGains(0.0, 0.0, 0.0)])
def test_the_transparent_modes_law_compiled_is_the_interpreted_one(gains):
    """The transparent mode's torque (every term of eq. 3.6 on in ROBOT), in the exercise
    vector the pipeline builds: the guidance's constants switched off, then its own."""
    from core.control.guidance import OFF

    vector = [*OFF, *gains.constants()]
    fast = compiled(transparent_torques)
    for q1, q2, v1, v2, a1, a2, *_ in poses():
        args = (q1, q2, v1, v2, a1, a2)
        assert same(fast(R, np.asarray(vector), *args),
                    transparent_torques(ROBOT.constants, vector, *args))


def test_the_rate_tracker_compiled_is_the_interpreted_one():
    estimator = RateEstimator(0.002, 20.0)
    fast = compiled(track)
    z_fast, z_slow = np.zeros(6), [0.0] * 6
    rng = np.random.default_rng(3)
    for angle in np.cumsum(rng.normal(0.0, 0.004, 2000)).tolist():
        fast(np.asarray(estimator.coefficients), z_fast, 3, angle)
        track(estimator.coefficients, z_slow, 3, angle)
        assert z_fast.tolist() == z_slow


@pytest.mark.parametrize(("kind", "options"), [(kind, {}) for kind in PATIENT_KINDS]
                         + [("weak", {"selectivity_loss": 0.5})])
def test_every_patients_torque_compiled_is_the_interpreted_one(kind, options):
    patient = make_patient(kind, ARM, THESIS_SUBJECT.trajectory(), seed=3, **options)
    fast = compiled(patient_torque)
    arrays = (np.asarray(patient.constants), patient.table, patient.episodes)
    rng = np.random.default_rng(4)
    ts0, te0 = patient.start_posture_rad
    for t in np.linspace(-1.0, THESIS_SUBJECT.trajectory().total_duration_s + 1.0, 400):
        ts, te = ts0 + rng.normal(0.0, 0.2), te0 + rng.normal(0.0, 0.2)
        tsd, ted = rng.normal(0.0, 2.0, 2)
        args = (float(t), float(ts), float(te), float(tsd), float(ted))
        assert same(fast(*arrays, *args), patient.torque(*args))


def test_the_supervisors_checks_compiled_are_the_interpreted_ones():
    """Ten thousand ticks of readings that wander into every check (NaN, stale samples,
    jumps, forces, speeds, lateness, e-stop, in and out of a small exercise area, with a
    trial running or not), with clears in between: every output and the whole state equal
    after every tick."""
    area = SafetyLimits().around_path([[-0.3, 0.3]], margin_m=0.03)
    slow, fast_sup = SafetySupervisor(ROBOT, area), SafetySupervisor(ROBOT, area)
    fast = compiled(checks.supervise)
    rng = np.random.default_rng(5)
    q1, q2 = ROBOT.ik([-0.3, 0.3])
    t = 0.0
    seen = set()  # (outside, driving, the condition WORKSPACE)
    for k in range(10_000):
        t += 0.002 if rng.random() > 0.01 else 0.0
        q1 += rng.normal(0.0, 0.002) + (0.3 if rng.random() < 0.002 else 0.0)
        q2 += rng.normal(0.0, 0.002)
        reading = [t, q1, q2, *rng.normal(0.0, 5.0, 2), 10.0]
        if rng.random() < 0.002:
            reading[rng.integers(6)] = math.nan
        if rng.random() < 0.003:
            reading[3] = 300.0
        args = (k * 0.002, *reading, *rng.normal(0.0, 1.5, 2), *rng.normal(0.0, 1.5, 2),
                float(rng.choice([0.0, 0.003, 0.012], p=[0.97, 0.02, 0.01])), 0.05,
                bool(rng.random() < 0.002), False, 0, bool(k // 500 % 2))
        assert same(fast(R, fast_sup.constants, fast_sup.state, *args),
                    checks.supervise(ROBOT.constants, slow.constants, slow.state, *args))
        np.testing.assert_array_equal(fast_sup.state, slow.state)
        seen.add((slow.outside_area, args[-1], slow.condition == checks.Fault.WORKSPACE))
        if slow.fault and rng.random() < 0.05 and not slow.clear_refusal():
            slow.clear()
            fast_sup.clear()
    # outside the area with no trial is no condition; with one it is the fault's
    assert {(True, False, False), (True, True, True)} <= seen, seen


# ------------------------------------------------------------------ flavours
def test_the_array_flavour_is_the_float_one_element_by_element():
    """To the last bit or two: numpy's vectorised tanh and sin are its own, not the C
    library's (the arrays are for analyses, which never compare bits)."""
    q = ROBOT.ik(np.random.default_rng(6).uniform([-0.4, 0.2], [-0.15, 0.45], (50, 2)))
    qd = np.random.default_rng(7).normal(0.0, 1.0, (50, 2))
    arrays = ARRAYS.of(robot_terms.friction_terms)(ROBOT.constants, *q.T, *qd.T)
    for i in range(50):
        one = robot_terms.friction_terms(ROBOT.constants, *q[i], *qd[i])
        assert arrays[0][i] == pytest.approx(one[0], rel=1e-14, abs=1e-17)
        assert arrays[1][i] == pytest.approx(one[1], rel=1e-14, abs=1e-17)


@kernel
def _double(x):
    return 2.0 * x


@kernel
def _twice_double(x):
    return _double(_double(x))


def test_a_flavour_rebinds_what_a_kernel_calls_and_only_in_its_own_copy():
    tripled = Flavour({"_double": lambda x: 3.0 * x}).of(_twice_double)
    assert tripled(1.0) == 9.0
    assert _twice_double(1.0) == 4.0  # the module's own functions are untouched
    assert interpreted(_twice_double) is _twice_double


def test_a_kernel_that_calls_another_through_its_module_is_refused():
    @kernel
    def through_the_module(q1, q2):
        return robot_terms.mass_terms((0.0,) * robot_terms.R_SIZE, q1, q2)

    with pytest.raises(TypeError, match="import it by name"):
        Flavour().of(through_the_module)


def test_only_kernels_have_flavours():
    with pytest.raises(TypeError, match="not a @kernel"):
        Flavour().of(math.cos)
