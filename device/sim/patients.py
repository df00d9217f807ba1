"""Virtual patients: the net shoulder and elbow torques τ_A of a subject holding the handle.

The simulator integrates the robot and the arm joined at the handle (core.interaction)
and asks the patient, at every evaluation of the dynamics, for τ_A given the time
and the arm's state. τ_A is the right-hand side of the arm's equation of motion
(eq. 3.20, 3.27) in core.arm's absolute angles (θ_s, θ_e):

    M_A θ̈_A + C_A θ̇_A = τ_A − J_Aᵀ F_hand

Muscles act across anatomical joints: the shoulder angle θ_s and the elbow angle
φ = θ_e − θ_s. Every model below is written in those joint coordinates, as the
impedance literature reports them, and mapped to τ_A by virtual work
(τ_sh δθ_s + τ_el δφ = (τ_sh − τ_el) δθ_s + τ_el δθ_e):

    τ_A = (τ_sh − τ_el, τ_el)

The parts of a patient
----------------------
* passive tissue (every kind): a relaxed arm's stiffness about the posture it
  started in and its damping, `PASSIVE_TISSUE`. Relaxed elbow and shoulder
  stiffness is a few N·m/rad in mid-range, an order of magnitude below the active
  values; the defaults are order-of-magnitude choices, not identified values.
* effort (every kind but passive): what the subject does to follow the path.
  The path becomes a desired arm motion θ_d(t) by the arm's inverse kinematics on
  the anatomical branch (eq. 3.16, vectorised over the trial with `arm.ik`), its
  rates and accelerations through J_A (eq. 3.18–3.19); the effort is

      feed-forward   M_A(θ_d) θ̈_d + C_A(θ_d, θ̇_d) θ̇_d − τ_tissue(θ_d, θ̇_d)
      + impedance    K (θ_d − θ) + B (θ̇_d − θ̇)             (joint coordinates)

  plus an active *drive*: a hand force of `drive_N` along the desired direction
  (the subject pushes the handle the way it should go, as the thesis's healthy
  subject did 78 % of the time, Fig. 3.9), with the direction low-passed by a
  first-order lag of `DRIVE_LAG_S` (muscle activation and anticipation: a subject
  cannot turn a push round instantly, so the push lags at the D's corners, where
  the thesis saw its red segments). The whole effort is
  scaled by `effort` (1 for a healthy subject). The feed-forward is the arm's
  own inverse dynamics (eq. 3.20 for the arm alone) plus what it takes to bend
  its own passive tissue, so on the desired motion a healthy arm's net torque is
  exactly M_A θ̈_d + C_A θ̇_d. The subject has no model of the robot: whatever
  the robot's inertia and friction ask for shows up as tracking error that the
  impedance corrects (about 10 mm RMS on the thesis's D with the motors off,
  tests/device/test_sim_patients.py). `HEALTHY_IMPEDANCE` is of the order
  measured during planar reaching (Gomi & Kawato 1997, Biol. Cybern. 76:163;
  Burdet et al. 2001, Nature 414:446: shoulder and elbow stiffness 10–20 N·m/rad,
  cross terms a third of that), with damping ≈ 0.08 s × stiffness, the order of
  the viscosity-to-stiffness ratio used in arm models (e.g. Tee et al. 2004,
  Biol. Cybern. 90:368). These are order-of-magnitude values quoted from memory
  of the literature, not identified on a subject; check them before citing.
* weak: the same effort scaled by `effort` = 0.4 by default: the paretic arm's
  voluntary torque after stroke is commonly a third to a half of the other
  side's; and half its selective joint control lost (selectivity below).
* synergy (an option of every kind but passive, 0 by default): the joints no longer
  move apart, as in the flexion synergy after stroke (Twitchell 1951, Brunnstrom 1970;
  Dewald & Beer, Muscle Nerve 24:273, 2001): the arm's own plan moves the elbow by
  `synergy` times the shoulder's change (`desired_motion_table`). It loses joint
  independence and flattens a drawn circle, as stroke survivors' circles are (Krabben et
  al., J NeuroEng Rehabil 8:15, 2011; Dipietro et al., J Neurophysiol 98:757, 2007): on
  the battery's circle at 0.3 the weak patient's ratio (its selectivity whole) went 0.95
  → 0.80–0.82 (healthy 0.88–0.91) and its joint independence 0.87 → 0.83–0.85. It is not
  the weak kind's default: the plan leaves the path, so wherever the robot holds the hand on it (the
  as-needed channel on the thesis's D) the arm pushes across the channel: from 0.15 up the
  weak patient's directional performance fell from 26–30 % to 2 %, the time it led from
  85–87 % to 24–37 %, and the hand left the path by 14–24 mm RMS (bench/synergy.py). A
  coupling of torques instead (the elbow given a share of the shoulder's voluntary torque)
  did neither: the arm's impedance pulled the hand back onto the path.
* selectivity (`selectivity_loss` κ and `synergy_direction_rad` α, options of every kind
  but passive; κ = 0.5 for the weak kind by default, DEFAULT_SELECTIVITY_LOSS, 0 for the
  others): the loss of selective joint control after stroke. A
  paretic arm makes torques along its synergy but hardly across it: asked for a torque at
  one joint it makes one at the other too, shoulder abduction coming with elbow flexion
  and adduction with extension (Dewald et al., Brain 118:495, 1995; Dewald & Beer, Muscle
  Nerve 24:273, 2001), and its reaching loses interjoint coordination (Levin, Brain
  119:281, 1996). The plan stays the path (the subject still means to follow it); what the
  arm makes of its command does not. In joint coordinates (τ_sh, τ_el) every voluntary
  torque keeps its part along the synergy's direction s = (cos α, sin α) and loses the
  share κ of its part across it (n = (−sin α, cos α)): the feed-forward and the push go
  through P = I − κ n nᵀ; the impedance becomes Q K Q and Q B Q, Q = I − (1 − √(1 − κ))
  n nᵀ, so its answer across the synergy loses the same share while the stiffness stays
  symmetric and positive definite (the arm creates no energy) with its equilibrium on the
  plan. Unlike `synergy`, the arm then does not push across a channel that holds the hand
  on the path. α = SYNERGY_DIRECTION_RAD (−67.5°): in this arm's coordinates (θ_s grows as
  the upper arm swings toward the midline, φ = θ_e − θ_s as the elbow bends) elbow flexion
  with horizontal abduction, the elbow leading (elbow flexion is the flexor synergy's
  strongest part, Brunnstrom 1970). The angle is our choice: the sources above measured the
  coupling, mostly with the arm abducted against gravity, not this angle. On the D (κ =
  0.5, as-needed) −50° to −79° behaved alike (the patient leading 82–87 % of the time,
  within 3.3 mm RMS of the path; its push in the cone 18–19 % of the time at −50°, 5–7 % at
  −79°) but at −45° the weak arm cut the D's arc (21–26 mm RMS, leading 39–41 %): −67.5°
  keeps away from that edge. Quoted from memory of the literature, as the impedance values
  above; check before citing. With κ = 0.5 the weak patient's circle flattens and its
  joints move together, both figures under the healthy patient's, while on the thesis's D
  with the as-needed assistance it leads as often as without and its push, bent toward
  the synergy, is in the cone a third as often; with the submovements of its own
  movements (device.sim.submovements) every figure of the battery then orders as a stroke
  survivor's. It is the weak kind's default since 2026-12-05, so the weak patient is one
  stroke survivor's arm in the battery and on the exercises alike; docs/validation.md
  measured the exercises again with it (under the thesis's full assistance this arm does
  no net work, the robot all of it; as needed it does a third). The figures are in
  docs/assessments.md (The virtual patients' circles, Submovements).
* spastic: healthy effort plus a velocity-dependent resistance on each joint
  (Lance's definition of spasticity: a velocity-dependent increase in the tonic
  stretch reflex),  τ = −b ω − g (|ω| − ω_th)₊ sign ω,  with ω the joint's rate.
* tremor: healthy effort plus τ = A sin(2π f t + ϕ) on both joints, f drawn
  uniformly in 4–6 Hz and ϕ in [0, 2π) from the seed (the band of parkinsonian
  rest tremor; post-stroke tremor is rarer but of the same order).
* wrong_way: healthy effort, but during episodes the push turns round: a hand
  force of `wrong_way_force_N` against the desired direction replaces the drive
  (τ = J_Aᵀ F). The time line
  is cut into windows of `wrong_way_episode_s / wrong_way_fraction`; each holds
  one episode at a random offset, so over whole windows the subject pushes the
  wrong way exactly `wrong_way_fraction` of the time (default 20 %, 0.5 s
  episodes, 3 N: above the thesis subject's force range of 0.8–2.5 N, Fig. 3.9,
  and within what the robot's 2.2 N·m joints can resist).

The desired motion and the feed-forward are tabulated once per traversal with numpy
every `TABLE_STEP_S` (device.sim.desired_motion) and interpolated linearly in time. The
interpolation matters: a sample-and-hold table is a discontinuous forcing that cuts RK4
to first order. The torque itself is a kernel (device.sim.patient_torque; core.kernels):
`VirtualPatient.torque` runs it interpreted, the simulator folds it, compiled, into
its dynamics (device.sim.physics).

Here: the patient (`VirtualPatient`) and its factory (`make_patient`, `trial_factors`);
the parameters, their defaults and checks are device.sim.patient_parameters', the
desired-motion table and the push's lag device.sim.desired_motion's.
"""

from __future__ import annotations

import math
from typing import Protocol, runtime_checkable

import numpy as np

from core.arm import ArmModel
from core.errors import ParameterError
from core.holdtasks import TaskTrajectory
from core.trajectory import Trajectory
from device.sim.desired_motion import desired_motion_table
from device.sim.holdtasks import TASK_OPTIONS, TaskBehaviour, behaviour, task_options
from device.sim.patient_parameters import (
    DEFAULT_EFFORT,
    DEFAULT_SELECTIVITY_LOSS,
    DRIVE_N,
    HEALTHY_IMPEDANCE,
    PASSIVE_TISSUE,
    PATIENT_KINDS,
    SYNERGY_DIRECTION_RAD,
    TREMOR_AMPLITUDE_NM,
    TREMOR_BAND_HZ,
    JointImpedance,
    PatientParameters,
    Spasticity,
    Tremor,
    WrongWay,
    check_pair,
    check_symmetric,
)
from device.sim.patient_torque import (
    P_EP_LEN,
    P_EP_WINDOW,
    P_EPISODES,
    P_PHI0,
    P_TOTAL,
    P_TS0,
    TABLE_STEP_S,
    constants_vector,
    desired_motion,
    patient_torque,
    pushing_wrong_way,
)

_TWO_PI = 2.0 * math.pi


@runtime_checkable
class Patient(Protocol):
    """What the simulator needs from a patient: the arm, the path they are asked to
    follow, and their net joint torques."""

    arm: ArmModel
    trajectory: Trajectory

    def torque(self, t_s: float, ts: float, te: float, tsd: float, ted: float):
        """Net joint torques τ_A = (τ_s, τ_e) in N·m at time `t_s` for the arm's
        absolute angles (θ_s, θ_e) and rates (eq. 3.20)."""



# -------------------------------------------------------------------- patient
class VirtualPatient:
    """A subject's arm with its own torques: passive tissue, effort and impairment.

    Build it with `make_patient`. The state it keeps is precomputed per trial
    (the desired motion, the tremor's frequency, the wrong-way episodes); `torque`
    itself is a pure function of its arguments, so runs are repeatable.
    """

    __slots__ = ("_episodes", "_table", "arm", "constants", "episodes", "parameters", "table",
                 "task", "trajectory")

    def __init__(
        self, parameters: PatientParameters, arm: ArmModel, trajectory: Trajectory, seed=0,
        task: TaskBehaviour | None = None,
    ) -> None:
        self.parameters = parameters
        self.arm = arm
        self.trajectory = trajectory
        rng = np.random.default_rng(seed)
        x0, y0, *_ = trajectory.at(0.0)
        ts0, te0 = (float(v) for v in arm.ik(np.array([x0, y0])))
        dx0, dy0 = trajectory.at(0.0)[6:8]
        table = np.empty((0, 18))
        self.task = task
        """In a task the robot leads, the patient's own plan (device.sim.holdtasks), else None."""
        if parameters.kind != "passive":
            own, drive = trajectory, parameters.drive_N
            if task is not None:
                own, drive = task.trajectory, task.drive_N
            table = desired_motion_table(arm, own, parameters.passive, (ts0, te0 - ts0), drive,
                                          parameters.synergy)
            if task is not None:
                # the task's own pushes (device.sim.holdtasks: a rise and a fall of its own)
                table = task.with_pushes(table, TABLE_STEP_S)
        episodes: list[float] = []
        ep_len = ep_window = 0.0
        if parameters.wrong_way is not None:
            ww = parameters.wrong_way
            ep_len = ww.episode_s
            ep_window = ww.episode_s / ww.fraction
            n_windows = math.ceil(trajectory.total_duration_s / ep_window)
            episodes = rng.uniform(0.0, ep_window - ww.episode_s, n_windows).tolist()
        self.constants = constants_vector(parameters, arm, trajectory, ts0, te0 - ts0,
                                          len(table), ep_len, ep_window, len(episodes),
                                          (dx0, dy0))
        """The vector `patient_torque` works from (its P_* names)."""
        # The kernels index a table row and the episodes: kept as numpy arrays for the
        # compiled simulator (never empty: numba wants a 2-D float array) and as Python
        # rows for the interpreted calls here, which they make several times faster. The
        # rows are made at the first such call: a long trial's take hundreds of MB, and a
        # compiled run never needs them.
        self.table = table if len(table) else np.zeros((1, 18))
        self.episodes = np.array(episodes if episodes else [0.0])
        self._table = None
        self._episodes = self.episodes.tolist()

    def _rows(self) -> list[tuple]:
        if self._table is None:
            self._table = [tuple(row) for row in self.table.tolist()]
        return self._table

    # ------------------------------------------------------------ properties
    @property
    def kind(self) -> str:
        return self.parameters.kind

    @property
    def tremor_frequency_hz(self) -> float:
        """The tremor's frequency, NaN for a patient without tremor."""
        tremor = self.parameters.tremor
        return math.nan if tremor is None else tremor.frequency_hz

    @property
    def episodes_s(self) -> tuple[tuple[float, float], ...]:
        """Start and end times of the wrong-way episodes (empty for other kinds)."""
        c = self.constants
        out = []
        for k in range(int(c[P_EPISODES])):
            start = k * c[P_EP_WINDOW] + self._episodes[k]
            if start < c[P_TOTAL]:
                out.append((start, min(start + c[P_EP_LEN], c[P_TOTAL])))
        return tuple(out)

    @property
    def start_posture_rad(self) -> tuple[float, float]:
        """Arm angles (θ_s, θ_e) at the path's start, the passive tissue's rest posture."""
        return (self.constants[P_TS0], self.constants[P_TS0] + self.constants[P_PHI0])

    def desired(self, t_s: float) -> tuple[float, ...]:
        """The desired motion at `t_s` as the patient looks it up:
        (θ_s, φ, θ̇_s, φ̇, feed-forward τ_s, τ_e, direction x, y, drive force x, y),
        φ = θ_e − θ_s."""
        return desired_motion(self.constants, self._rows(), t_s)

    def pushing_wrong_way(self, t_s: float) -> bool:
        """True during a wrong-way episode."""
        return pushing_wrong_way(self.constants, self._episodes, t_s)

    # ---------------------------------------------------------------- torque
    def torque(self, t_s: float, ts: float, te: float, tsd: float, ted: float):
        """Net joint torques τ_A = (τ_s, τ_e) in N·m (eq. 3.20), absolute-angle convention:
        the kernel `patient_torque` (the model of the module notes: passive tissue, then
        the effort, impedance about the desired motion, feed-forward and the push,
        linearly interpolated in time so the integrator keeps its order, the wrong-way
        push, tremor and spastic resistance)."""
        return patient_torque(self.constants, self._rows(), self._episodes, t_s, ts, te, tsd,
                              ted)



# -------------------------------------------------------------------- factory
_IMPEDANCE_OPTIONS = ("passive_stiffness_Nm_rad", "passive_damping_Nms_rad", "variability",
                      *TASK_OPTIONS)
_EFFORT_OPTIONS = ("effort", "stiffness_Nm_rad", "damping_Nms_rad", "drive_N", "synergy",
                   "selectivity_loss", "synergy_direction_rad")
_OPTIONS = {
    "passive": _IMPEDANCE_OPTIONS,
    "healthy": _IMPEDANCE_OPTIONS + _EFFORT_OPTIONS,
    "weak": _IMPEDANCE_OPTIONS + _EFFORT_OPTIONS,
    "spastic": _IMPEDANCE_OPTIONS + _EFFORT_OPTIONS
    + ("spastic_threshold_rad_s", "reflex_gain_Nms_rad", "spastic_viscous_Nms_rad"),
    "tremor": _IMPEDANCE_OPTIONS + _EFFORT_OPTIONS + ("tremor_hz", "tremor_amplitude_Nm"),
    "wrong_way": _IMPEDANCE_OPTIONS + _EFFORT_OPTIONS
    + ("wrong_way_fraction", "wrong_way_episode_s", "wrong_way_force_N"),
}
VARIABILITY = 0.1
"""Coefficient of variation of a subject's effort and drive from one trial to the next
(every kind but passive): people never do a movement twice alike, and a stroke survivor's
force output varies by some 10-20 % from attempt to attempt (an order of magnitude, as
the impedance values above, not identified on a subject). Drawn by the trial's seed, so a
course of simulated trials at one setting varies (a new seed each trial) and a trial runs
again the same with its seed; 0 makes every trial the subject's mean."""


def make_patient(
    kind: str, arm: ArmModel, trajectory: Trajectory, *, seed=0, **options
) -> VirtualPatient:
    """A virtual patient of one of PATIENT_KINDS for `arm` following `trajectory`.

    `seed` (an int or a numpy SeedSequence) draws the tremor's frequency and
    phase and the wrong-way episodes. `options` override the defaults documented
    in this module; each kind accepts its own (pairs are (shoulder, elbow),
    matrices (shoulder, cross, elbow)):

      every kind      passive_stiffness_Nm_rad, passive_damping_Nms_rad, variability
                      (the trial-to-trial coefficient of variation of effort and drive,
                      default VARIABILITY, each trial's factors drawn by `seed`; nothing
                      for a passive patient, who has neither), strength_N and
                      proprioception_sd_m (the tasks the robot leads, device.sim.holdtasks)
      but passive     effort, stiffness_Nm_rad, damping_Nms_rad, drive_N, synergy,
                      selectivity_loss, synergy_direction_rad
      spastic         spastic_threshold_rad_s, reflex_gain_Nms_rad, spastic_viscous_Nms_rad
      tremor          tremor_hz (None: drawn in 4–6 Hz), tremor_amplitude_Nm
      wrong_way       wrong_way_fraction, wrong_way_episode_s, wrong_way_force_N

    Unknown kinds and options, and values out of range, raise ParameterError
    naming them. A path out of the arm's reach raises UnreachableError.
    """
    if kind not in PATIENT_KINDS:
        raise ParameterError(
            "kind", kind, "one of " + ", ".join(PATIENT_KINDS), "no such virtual patient"
        )
    allowed = _OPTIONS[kind]
    for name, value in options.items():
        if name not in allowed:
            raise ParameterError(
                name, value, f"the options of a {kind} patient: " + ", ".join(allowed),
                "unknown option",
            )
    rng = np.random.default_rng(seed)

    # Each value is checked under its option's name before the dataclasses see it.
    def symmetric(name, default):
        return check_symmetric(name, options.get(name, default))

    def pair(name, default):
        return check_pair(name, options.get(name, default))

    passive = JointImpedance(
        symmetric("passive_stiffness_Nm_rad", PASSIVE_TISSUE.stiffness_Nm_rad),
        symmetric("passive_damping_Nms_rad", PASSIVE_TISSUE.damping_Nms_rad),
    )
    active = JointImpedance(
        symmetric("stiffness_Nm_rad", HEALTHY_IMPEDANCE.stiffness_Nm_rad),
        symmetric("damping_Nms_rad", HEALTHY_IMPEDANCE.damping_Nms_rad),
    )
    spasticity = tremor = wrong_way = None
    if kind == "spastic":
        default = Spasticity()
        spasticity = Spasticity(
            pair("spastic_threshold_rad_s", default.threshold_rad_s),
            pair("reflex_gain_Nms_rad", default.reflex_gain_Nms_rad),
            pair("spastic_viscous_Nms_rad", default.viscous_Nms_rad),
        )
    if kind == "tremor":
        # Both draws always happen, so the phase does not depend on whether the
        # frequency was given.
        drawn_hz = float(rng.uniform(*TREMOR_BAND_HZ))
        phase = float(rng.uniform(0.0, _TWO_PI))
        frequency = options.get("tremor_hz")
        tremor = Tremor(
            drawn_hz if frequency is None else frequency,
            options.get("tremor_amplitude_Nm", TREMOR_AMPLITUDE_NM),
            phase,
        )
    if kind == "wrong_way":
        default_ww = WrongWay()
        wrong_way = WrongWay(
            options.get("wrong_way_fraction", default_ww.fraction),
            options.get("wrong_way_episode_s", default_ww.episode_s),
            options.get("wrong_way_force_N", default_ww.force_N),
        )
    effort = options.get("effort", DEFAULT_EFFORT.get(kind, 1.0))
    drive = options.get("drive_N", DRIVE_N)
    synergy = options.get("synergy", 0.0)
    loss = options.get("selectivity_loss", DEFAULT_SELECTIVITY_LOSS.get(kind, 0.0))
    direction = options.get("synergy_direction_rad", SYNERGY_DIRECTION_RAD)
    PatientParameters(kind, effort, passive, active, spasticity, tremor, wrong_way, drive,
                      synergy, loss, direction)
    effort_factor, drive_factor = trial_factors(seed, options.get("variability", VARIABILITY))
    if kind != "passive":  # the subject's mean checked above; this trial's draw below
        # a healthy subject's effort is the model's whole effort (1): a trial varies it
        # down, never beyond
        effort, drive = min(1.0, effort * effort_factor), drive * drive_factor
    parameters = PatientParameters(kind, effort, passive, active, spasticity, tremor,
                                   wrong_way, drive, synergy, loss, direction)
    strength, proprioception = task_options(kind, options)
    task = None
    if isinstance(trajectory, TaskTrajectory) and kind != "passive":
        task = behaviour(trajectory, effort, strength, proprioception, seed, arm)
    return VirtualPatient(parameters, arm, trajectory, rng, task)


def trial_factors(seed, variability: float) -> tuple[float, float]:
    """How much this trial's effort and drive differ from the subject's mean: two
    independent log-normal factors of mean 1 and coefficient of variation `variability`,
    drawn by `seed` from a stream of their own (so the tremor's and the wrong-way
    episodes' draws of a seed stay what they were)."""
    if not (math.isfinite(variability) and 0.0 <= variability <= 1.0):
        raise ParameterError("variability", variability, "0 to 1", "a coefficient of variation")
    if variability == 0.0:
        return 1.0, 1.0
    if isinstance(seed, np.random.SeedSequence):
        stream = np.random.SeedSequence(seed.entropy, spawn_key=(*seed.spawn_key, 13))
    else:
        stream = np.random.SeedSequence(int(seed), spawn_key=(13,))
    sigma = math.sqrt(math.log1p(variability ** 2))
    drawn = np.random.default_rng(stream).normal(-sigma ** 2 / 2, sigma, 2)
    return float(math.exp(drawn[0])), float(math.exp(drawn[1]))
