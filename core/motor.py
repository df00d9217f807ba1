"""The motor side of a joint: torque constant, belt reduction, limits and encoder (Table 3.1).

Each joint is driven by a DC motor through a disc-and-timing-belt reduction
(section 3.2.1). We read Table 3.1's "16 : 307" as a 16-tooth pulley on the
motor shaft driving a 307-tooth disc on the joint, so the gear sits between
motor and joint and

    joint torque = motor torque · (307 / 16)       (speed reduced by the same factor)
    motor current = joint torque / (K_T · 307 / 16)

Table 3.1 calls the 4000 counts/rev encoder a *motor* encoder, so by default it
turns with the motor shaft and one joint revolution is 4000 · 307/16 counts.
Both readings are parameters: a robot with the encoder on the joint sets
`encoder_on_motor=False`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from core.errors import check_positive

THESIS_GEAR_RATIO = 307.0 / 16.0


@dataclass(frozen=True, slots=True)
class MotorParameters:
    """One joint's drive: DC motor, belt reduction and incremental encoder.

    Defaults are Table 3.1. `peak_factor` scales the rated current to the
    current the amplifier may deliver for short bursts; the thesis gives only
    the rated torque, so the default is 1 (continuous rating, the safe reading).
    """

    torque_constant_Nm_per_A: float = 0.115
    gear_ratio: float = THESIS_GEAR_RATIO
    rated_torque_Nm: float = 0.115
    peak_factor: float = 1.0
    encoder_counts_per_rev: int = 4000
    encoder_on_motor: bool = True

    def __post_init__(self) -> None:
        check_positive("torque_constant_Nm_per_A", self.torque_constant_Nm_per_A, "N·m/A")
        check_positive("gear_ratio", self.gear_ratio)
        check_positive("rated_torque_Nm", self.rated_torque_Nm, "N·m")
        check_positive("peak_factor", self.peak_factor)
        check_positive("encoder_counts_per_rev", self.encoder_counts_per_rev, "counts/rev")

    @property
    def max_current_A(self) -> float:
        """Largest current command: rated motor torque / K_T, times the peak factor."""
        return self.rated_torque_Nm / self.torque_constant_Nm_per_A * self.peak_factor

    @property
    def max_joint_torque_Nm(self) -> float:
        """Largest joint torque the drive may deliver (2.21 N·m for the thesis robot)."""
        return self.max_current_A * self.torque_constant_Nm_per_A * self.gear_ratio

    @property
    def counts_per_joint_rev(self) -> float:
        """Encoder counts for one revolution of the joint."""
        if self.encoder_on_motor:
            return self.encoder_counts_per_rev * self.gear_ratio
        return float(self.encoder_counts_per_rev)

    @property
    def joint_angle_resolution_rad(self) -> float:
        """Smallest joint-angle step the encoder resolves."""
        return 2.0 * math.pi / self.counts_per_joint_rev

    def current_from_joint_torque(self, torque_Nm: float) -> float:
        """Motor current for a joint torque: τ / (K_T · gear)."""
        return torque_Nm / (self.torque_constant_Nm_per_A * self.gear_ratio)

    def joint_torque_from_current(self, current_A: float) -> float:
        """Joint torque produced by a motor current: I · K_T · gear."""
        return current_A * self.torque_constant_Nm_per_A * self.gear_ratio

    def counts_from_joint_angle(self, angle_rad: float) -> int:
        """Encoder count for a joint angle measured from the encoder's zero."""
        return round(angle_rad * self.counts_per_joint_rev / (2.0 * math.pi))

    def joint_angle_from_counts(self, counts: float) -> float:
        """Joint angle for an encoder count."""
        return counts * 2.0 * math.pi / self.counts_per_joint_rev

    def quantise_joint_angle(self, angle_rad: float) -> float:
        """The angle the encoder reports for a true joint angle."""
        return self.joint_angle_from_counts(self.counts_from_joint_angle(angle_rad))
