"""What defines a virtual patient besides the arm and the path: its kind, its joint
impedances and the parameters of its impairments (spasticity, tremor, pushing the wrong
way, synergy, loss of selectivity), each checked as it is built.

What each means, where the values come from and how the patient uses them are
device.sim.patients' module notes; `make_patient` (there) builds these from a kind and
its options.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.errors import ParameterError, check_finite, check_non_negative, check_range
from device.sim.patient_torque import spastic_resistance

SYNERGY_MAX = 0.8
"""A coupling beyond which the elbow would follow the shoulder almost wholly."""
SELECTIVITY_LOSS_MAX = 0.9
"""A loss beyond which the arm could hardly push out of its synergy at all."""
SYNERGY_DIRECTION_RAD = -3.0 * math.pi / 8.0
"""The flexion synergy's direction α in joint-coordinate torques (τ_sh, τ_el) =
(cos α, sin α), −67.5°: elbow flexion with shoulder horizontal abduction (and elbow
extension with adduction), the elbow's share 2.4 times the shoulder's (device.sim.patients'
module notes, selectivity)."""

PATIENT_KINDS = ("healthy", "weak", "spastic", "tremor", "passive", "wrong_way")
DEFAULT_EFFORT = {"passive": 0.0, "weak": 0.4}
"""Effort by kind; every other kind defaults to 1 (a healthy subject's effort)."""
DEFAULT_SELECTIVITY_LOSS = {"weak": 0.5}
"""The loss of selective joint control κ by kind; every other kind defaults to 0."""
TREMOR_BAND_HZ = (4.0, 6.0)
# Allowed when the frequency is given rather than drawn: the range of pathological
# tremors of the arm.
TREMOR_RANGE_HZ = (3.0, 12.0)
TREMOR_AMPLITUDE_NM = (0.5, 0.8)
DRIVE_N = 1.2
"""A healthy subject's push along the path: the thesis's subject's force ranged over
0.8 N (x) and 2.5 N (y) on the D (Fig. 3.9), i.e. about ±1.2 N along the line."""
DRIVE_RANGE_N = (0.0, 20.0)


# ----------------------------------------------------------------- validation
def check_pair(name: str, value) -> tuple[float, float]:
    """A (shoulder, elbow) pair of non-negative values, refused under `name` otherwise
    (make_patient checks each option under its own name)."""
    try:
        a, b = value
    except (TypeError, ValueError):
        raise ParameterError(name, value, "a pair (shoulder, elbow)") from None
    return (check_non_negative(f"{name}[0]", a), check_non_negative(f"{name}[1]", b))


def check_symmetric(name: str, value) -> tuple[float, float, float]:
    """A symmetric positive semi-definite matrix given as (shoulder, cross, elbow), refused
    under `name` otherwise: an impedance that is not would create energy."""
    try:
        a, c, b = value
    except (TypeError, ValueError):
        raise ParameterError(name, value, "a triple (shoulder, cross, elbow)") from None
    a = check_non_negative(f"{name}[shoulder]", a)
    b = check_non_negative(f"{name}[elbow]", b)
    c = check_finite(f"{name}[cross]", c)
    if c * c > a * b:
        raise ParameterError(
            f"{name}[cross]", c, f"|cross| <= sqrt(shoulder·elbow) = {math.sqrt(a * b):g}",
            "the matrix must be positive semi-definite, or the arm would create energy",
        )
    return (a, c, b)


# ------------------------------------------------------------------ parameters
@dataclass(frozen=True, slots=True)
class JointImpedance:
    """Stiffness and damping in joint coordinates (shoulder θ_s, elbow θ_e − θ_s).

    Each is a symmetric matrix given as (shoulder, cross, elbow). Both must be
    positive semi-definite, or the arm would create energy.
    """

    stiffness_Nm_rad: tuple[float, float, float]
    damping_Nms_rad: tuple[float, float, float]

    def __post_init__(self) -> None:
        object.__setattr__(
            self, "stiffness_Nm_rad", check_symmetric("stiffness_Nm_rad", self.stiffness_Nm_rad)
        )
        object.__setattr__(
            self, "damping_Nms_rad", check_symmetric("damping_Nms_rad", self.damping_Nms_rad)
        )


HEALTHY_IMPEDANCE = JointImpedance((15.0, 5.0, 12.0), (1.2, 0.4, 1.0))
"""Active impedance of a healthy subject reaching in the plane (device.sim.patients' module
notes)."""

PASSIVE_TISSUE = JointImpedance((1.0, 0.0, 0.6), (0.2, 0.0, 0.15))
"""A relaxed arm: passive joint stiffness and damping (device.sim.patients' module notes)."""


@dataclass(frozen=True, slots=True)
class Spasticity:
    """Velocity-dependent resistance per joint (shoulder, elbow):
    τ = −b ω − g (|ω| − ω_th)₊ sign ω."""

    threshold_rad_s: tuple[float, float] = (0.5, 0.5)
    reflex_gain_Nms_rad: tuple[float, float] = (1.5, 2.0)
    viscous_Nms_rad: tuple[float, float] = (0.3, 0.5)

    def __post_init__(self) -> None:
        for name in ("threshold_rad_s", "reflex_gain_Nms_rad", "viscous_Nms_rad"):
            object.__setattr__(self, name, check_pair(name, getattr(self, name)))


@dataclass(frozen=True, slots=True)
class Tremor:
    """A sinusoidal torque on both joints (shoulder, elbow amplitudes)."""

    frequency_hz: float
    amplitude_Nm: tuple[float, float] = TREMOR_AMPLITUDE_NM
    phase_rad: float = 0.0

    def __post_init__(self) -> None:
        check_range("tremor_hz", self.frequency_hz, *TREMOR_RANGE_HZ, "Hz",
                    "the range of pathological tremors of the arm")
        object.__setattr__(self, "amplitude_Nm",
                           check_pair("tremor_amplitude_Nm", self.amplitude_Nm))
        check_finite("phase_rad", self.phase_rad, "rad")


@dataclass(frozen=True, slots=True)
class WrongWay:
    """Episodes of pushing against the desired direction: `fraction` of the time,
    in episodes of `episode_s`, with a hand force of `force_N`."""

    fraction: float = 0.2
    episode_s: float = 0.5
    force_N: float = 3.0

    def __post_init__(self) -> None:
        check_range("wrong_way_fraction", self.fraction, 0.0, 0.9, "", low_open=True)
        check_range("wrong_way_episode_s", self.episode_s, 0.01, 60.0, "s")
        check_range("wrong_way_force_N", self.force_N, 0.0, 50.0, "N",
                    "a hand force the robot's drives can meet")


@dataclass(frozen=True, slots=True)
class PatientParameters:
    """Everything that defines a virtual patient besides the arm and the path."""

    kind: str
    effort: float
    passive: JointImpedance = PASSIVE_TISSUE
    active: JointImpedance = HEALTHY_IMPEDANCE
    spasticity: Spasticity | None = None
    tremor: Tremor | None = None
    wrong_way: WrongWay | None = None
    drive_N: float = DRIVE_N
    synergy: float = 0.0
    """The flexion synergy's coupling: the elbow's planned angle moves by this times the
    shoulder's change (device.sim.patients' module notes, synergy)."""
    selectivity_loss: float = 0.0
    """The share of the voluntary command across the synergy's direction that the arm
    loses (device.sim.patients' module notes, selectivity)."""
    synergy_direction_rad: float = SYNERGY_DIRECTION_RAD
    """The synergy's direction α in joint-coordinate torques (τ_sh, τ_el) = (cos α, sin α)."""

    def __post_init__(self) -> None:
        check_range("drive_N", self.drive_N, *DRIVE_RANGE_N, "N",
                    "a push along the path the robot's drives can meet")
        if self.kind not in PATIENT_KINDS:
            raise ParameterError("kind", self.kind, "one of " + ", ".join(PATIENT_KINDS))
        check_range("effort", self.effort, 0.0, 1.0, "",
                    "the fraction of a healthy subject's effort")
        check_range("synergy", self.synergy, 0.0, SYNERGY_MAX, "",
                    "how far the elbow's plan follows the shoulder's (rad/rad)")
        check_range("selectivity_loss", self.selectivity_loss, 0.0, SELECTIVITY_LOSS_MAX, "",
                    "the share of the command out of synergy the arm loses")
        check_range("synergy_direction_rad", self.synergy_direction_rad, -math.pi / 2,
                    math.pi / 2, "rad", "a direction of joint torques (the opposite one is "
                    "the same synergy)")


def spastic_resistance_Nm(parameters: Spasticity, shoulder_rate_rad_s, elbow_rate_rad_s):
    """The spastic resistance (τ_sh, τ_el) for joint rates, in joint coordinates; the
    patient subtracts it from its torques."""
    th_s, th_e = parameters.threshold_rad_s
    g_s, g_e = parameters.reflex_gain_Nms_rad
    b_s, b_e = parameters.viscous_Nms_rad
    return (
        spastic_resistance(shoulder_rate_rad_s, th_s, g_s, b_s),
        spastic_resistance(elbow_rate_rad_s, th_e, g_e, b_e),
    )
