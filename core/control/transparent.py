"""The transparent mode: the robot compensates its own inertia, friction and stiffness as
well as its model allows and adds no guidance, so that the patient moving the handle
feels as little of the robot as it can give (for games and assessments, where the
patient's own movement is what is measured).

This is the `transparent` assistance mode of a trial (`TrialParameters.assist`); the
others are `thesis` (core.control.assistance) and `as-needed` (core.control.guidance).

The law, each tick of the exercise
----------------------------------
The robot's own dynamics are eq. 3.6,

    M_R θ̈ + C_R θ̇ + K_R (θ − θ_R0) + J_Rᵀ f_RE + f_RJ = τ_R + J_Rᵀ F_hand,

so a motor torque equal to the left-hand side would leave the hand force F_hand = 0
(a massless, frictionless robot). The motors give the model's share of each term:

    τ = c_m (M̂_R(θ) θ̈̂ + Ĉ_R(θ, θ̇) θ̇) + c_f f̂(θ̇) + c_k K̂_R (θ − θ_R0)

with M̂, Ĉ, f̂, K̂ the controller's model of the robot (eq. 3.7–3.14, core.robot_terms),
θ̇ and θ̈̂ the rate tracker's estimates (core.signal.RateEstimator, 20 Hz), and the
shares c_m = `inertia`, c_f = `friction`, c_k = `stiffness` (the `gains` line:
`transparent.inertia=0.5`).

* **Friction** f̂ is the model's joint and handle friction (core.robot.Friction), whose
  Coulomb term is already smoothed (c tanh(θ̇/v_s)): a sign function would switch the
  full Coulomb torque on every zero crossing of a noisy rate and chatter at rest, the
  usual trouble of model-based friction compensation. c_f < 1 (at most 0.95) leaves part
  of the modelled friction as dissipation: what is left is the damping that pays for the
  energy the inertia compensation's lag injects (below), and for the friction the model
  over-estimates on a robot that has less of it.
* **Stiffness** K̂(θ − θ_R0), the cables' spring, is a function of the measured angles
  alone (no estimate, no lag): compensated in full by default.
* **Inertia**: c_m (M̂ θ̈̂ + Ĉ θ̇) is the share c_m of the robot's inertial torque.
  With the true acceleration its power is c_m d/dt(½ θ̇ᵀ M θ̇) (Ṁ − 2C is skew,
  eq. 3.8): the apparent mass becomes (1 − c_m) M and nothing is injected. But θ̈ is
  only known through a filter of the encoders (quantised to 4000 counts/rev on the
  motor): θ̈̂ lags θ̈ by about 24 ms at 20 Hz, and a mass term fed a lagging acceleration
  is not passive: at frequency ω it acts as a negative damping of about c_m M ω² τ_lag,
  which the friction left over must outweigh, and it amplifies the encoder noise the
  filter lets through. This is why impedance-type robots compensate inertia only in
  part, and why a force-sensor loop is not the way out either: inertia reduction by
  either is bounded for coupled stability (Colgate & Hogan 1988, Int J Control 48:65,
  passivity; Newman 1992, ASME J Dyn Syst 114:41, inertia reduction with force
  feedback; Buerger & Hogan 2007, IEEE Trans Robot 23:1164, "complementary stability";
  quoted from memory of the literature, check them before citing). c_m is at most 0.9
  so that the apparent mass never reaches zero; its default was chosen on the
  simulator's realistic plant (bench/transparency.py, docs/performance.md).
* **No force feedback.** Amplifying the sensed hand force, τ += k J_Rᵀ F, would also take
  away the friction the model does not know. Tried on a prototype of this law on
  2026-12-03 (not kept in the code): at 0.3 m/s on the realistic plant k = 0.5 and 1 lowered
  the felt force from 0.62 to 0.41 and 0.32 N RMS, but doubled the torque's chatter at
  k = 1, and at k = 1.5 the passive, weak, spastic and healthy patients' trials on the D
  saturated the drives for a second (the supervisor's fault): a stability margin under 2
  on a simulator whose hand is rigidly held, too little for a real handle.

No guidance: no channel, no reference that pulls, no help along the path: the
transparent torque does not depend on the path or the clock. The path's reference is
still recorded (where the clock is on the path) and the cone test of the patient's push
(core.control.assistance.cone_test) still says whether the push pointed along the path,
for the directional performance; it changes no torque. The safety supervisor stays as in
every mode. The approach to the path's start runs the trial's tracking controller on the
clock, as in the other modes (device.loop.pipeline): the patient is brought to the start.
The hold after the exercise (0.5 s) stays transparent, unlike the other modes, where the
controller holds the hand at the path's end: a patient free to move is not pulled back to
where the clock ended. On the thesis's D (two laps, realistic plant, seed 0) the hold's
controller pulled a wrong-way patient who ended 24 mm from the path's end with the drives'
full 2.2 N·m (3.1 N felt); transparent, the hold's largest torque is 0.31 N·m (0.73 N).

The assistance level has nothing to act on here: a transparent trial's level is 0
(core.trial.TrialParameters) and the loop refuses to change it.

The constants are appended to the guidance's in the pipeline's exercise vector
(`TransparentGains.constants`, the TC_* names after core.control.guidance's GC_*); the
law is the kernel `transparent_torques` (core.kernels), compiled in the loop.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace

from core.control.guidance import GC_SIZE
from core.errors import check_range
from core.kernels import kernel
from core.robot_terms import coriolis_of, friction_of, mass_of, stiffness_terms, trig


@dataclass(frozen=True, slots=True)
class TransparentGains:
    """The shares of the model's terms the motors compensate (module notes), each
    checked against its range by name."""

    inertia: float = 0.7
    friction: float = 0.9
    stiffness: float = 1.0

    def __post_init__(self) -> None:
        for f in fields(self):
            low, high, unit, why = TRANSPARENT_RANGES[f.name]
            check_range(f.name, getattr(self, f.name), low, high, unit, why)

    def replace(self, **changes) -> TransparentGains:
        return replace(self, **changes)

    def to_dict(self) -> dict:
        return {f.name: getattr(self, f.name) for f in fields(self)}

    def constants(self) -> list[float]:
        """The transparent part of the exercise vector (TC_* less GC_SIZE), switched on."""
        c = [0.0] * (TC_SIZE - GC_SIZE)
        c[TC_ON - GC_SIZE] = 1.0
        c[TC_INERTIA - GC_SIZE] = self.inertia
        c[TC_FRICTION - GC_SIZE] = self.friction
        c[TC_STIFFNESS - GC_SIZE] = self.stiffness
        return c


TRANSPARENT_RANGES = {
    # name: (low, high, unit, why)
    "inertia": (0.0, 0.9, "", "share of the robot's modelled inertia compensated from the "
                "estimated acceleration; below 1 so the robot keeps some mass (a lagging "
                "estimate makes more unstable)"),
    "friction": (0.0, 0.95, "", "share of the modelled friction compensated; below 1 so "
                 "that the robot stays dissipative"),
    "stiffness": (0.0, 1.0, "", "share of the modelled joint stiffness compensated"),
}

# The transparent mode's constants, after the guidance's in the exercise vector.
TC_ON, TC_INERTIA, TC_FRICTION, TC_STIFFNESS, TC_SIZE = range(GC_SIZE, GC_SIZE + 5)
OFF = (0.0,) * (TC_SIZE - GC_SIZE)
"""The transparent part of a trial in another mode."""


@kernel
def transparent_torques(robot, x, q1, q2, qd1, qd2, qdd1, qdd2):
    """The transparent mode's joint torques (N·m, the module notes' law) for the measured
    angles, the estimated rates and accelerations, on the robot's model constants `robot`
    and the exercise vector `x` (its TC_* entries)."""
    t = trig(q1, q2)
    m11, m12, m22 = mass_of(robot, t)
    _, c12, c21, _ = coriolis_of(robot, t, qd1, qd2)
    f1, f2 = friction_of(robot, t, qd1, qd2)
    k1, k2 = stiffness_terms(robot, q1, q2)
    ci = x[TC_INERTIA]
    cf = x[TC_FRICTION]
    ck = x[TC_STIFFNESS]
    tau1 = ci * (m11 * qdd1 + m12 * qdd2 + c12 * qd2) + cf * f1 + ck * k1
    tau2 = ci * (m12 * qdd1 + m22 * qdd2 + c21 * qd1) + cf * f2 + ck * k2
    return tau1, tau2
