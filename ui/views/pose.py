"""What the Joint angles tab shows of the camera (a trial's `/pose` group, written by
`rehab pose`): the camera's ISB angles beside the equation solver's, and their agreement
per joint as Table 3.4 gives it (RMSE and bias), with the shoulder's drift. Qt-free."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ui.views.numbers import format_number

JOINTS = ("shoulder", "elbow")


@dataclass(frozen=True, slots=True)
class PoseView:
    """`time_s` (N,) and `angle_isb_rad` (N, 2): the camera's angles at the trial's samples
    (NaN in gaps); `rmse_rad`, `bias_rad` per joint (camera − solver); the drift."""

    time_s: np.ndarray
    angle_isb_rad: np.ndarray
    rmse_rad: tuple[float, float]
    bias_rad: tuple[float, float]
    samples: tuple[int, int]
    max_drift_m: float
    drift_limit_m: float
    drift_exceeded: bool
    fit_residual_mm: float
    video: str

    @classmethod
    def from_group(cls, group: dict, time_s) -> PoseView | None:
        """From app.pose.store.read_pose's dict (None when the trial has no pose)."""
        if group is None or "angle_isb" not in group:
            return None
        a = group["attrs"]

        def number(key):
            value = a.get(key, math.nan)
            return float(value) if value is not None else math.nan

        return cls(
            time_s=np.asarray(time_s, dtype=float),
            angle_isb_rad=np.asarray(group["angle_isb"], dtype=float),
            rmse_rad=tuple(number(f"camera_vs_solver_{j}_rmse_rad") for j in JOINTS),
            bias_rad=tuple(number(f"camera_vs_solver_{j}_bias_rad") for j in JOINTS),
            samples=tuple(_count(number(f"camera_vs_solver_{j}_n")) for j in JOINTS),
            max_drift_m=number("shoulder_max_drift_m"),
            drift_limit_m=number("shoulder_drift_limit_m"),
            drift_exceeded=bool(a.get("shoulder_drift_exceeded", 0)),
            fit_residual_mm=number("fit_residual_mm"),
            video=str(a.get("video", "")),
        )

    def comparison_text(self) -> str:
        """Plain lines for the panel: per joint RMSE and bias in degrees, and the drift."""
        lines = [f"Camera ({self.video}) against the solver, as thesis Table 3.4:"]
        for j, joint in enumerate(JOINTS):
            lines.append(f"{joint.capitalize()}: {format_number(math.degrees(self.rmse_rad[j]))}° "
                         f"RMSE, {format_number(math.degrees(self.bias_rad[j]))}° bias")
        drift = f"Shoulder moved up to {format_number(100 * self.max_drift_m)} cm"
        if self.drift_exceeded:
            drift += (f": more than the {format_number(100 * self.drift_limit_m)} cm allowed; "
                      "the solver's angles assume it still")
        lines.append(drift)
        return "\n".join(lines)


def _count(value: float) -> int:
    return int(value) if math.isfinite(value) else 0
