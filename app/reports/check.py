"""The `check` report: a trial's parameters, the subject's arm model, whether the path
is reachable, and the joint-angle ranges it asks for, as plain text for a terminal."""

from __future__ import annotations

import math

from app.reports.plain_language import SHAPE_NAMES
from core.trial_check import TrialCheck


def format_check(check: TrialCheck) -> str:
    """A report a therapist can read: degrees and centimetres at the display only."""
    p = check.parameters
    arm = check.arm
    lines = [
        "Trial",
        f"  exercise        {SHAPE_NAMES[p.shape]}, centre ({p.centre_m[0]:+.3f}, "
        f"{p.centre_m[1]:+.3f}) m, radius {p.radius_m:.3f} m",
        f"  timing          {p.duration_s:g} s per traversal × {p.repetitions}, "
        f"{p.timing.replace('_', ' ')}",
        f"  path            {check.path_length_m:.3f} m per traversal, "
        f"peak speed {check.peak_speed_m_s:.3f} m/s",
        f"  controller      {p.controller.upper()}, "
        f"tolerance {math.degrees(p.tolerance_rad):.0f}°, "
        f"assistance {100 * p.assistance_level:.0f} %",
        "",
        f"Subject's arm ({p.side}, {p.body_mass_kg:g} kg; "
        "Winter's table, hand lumped at the handle)",
        f"  shoulder        ({arm.shoulder_x_m:+.3f}, {arm.shoulder_y_m:+.3f}) m",
        f"  upper arm       {arm.upper_arm_m:.4f} m, {arm.upper_arm_mass_kg:.3f} kg, "
        f"centre of mass {arm.upper_arm_com_m:.4f} m, "
        f"inertia {arm.upper_arm_inertia_kgm2:.5f} kg·m²",
        f"  forearm + hand  {arm.forearm_m:.4f} m, {arm.forearm_mass_kg:.3f} kg, "
        f"centre of mass {arm.forearm_com_m:.4f} m, "
        f"inertia {arm.forearm_inertia_kgm2:.5f} kg·m²",
        f"  reach           {arm.reach_max_m:.3f} m straight; the path is "
        f"{check.shoulder_distance_m.min():.3f}–{check.shoulder_distance_m.max():.3f} m "
        "from the shoulder",
        "",
        "Reachability",
        f"  robot           {_share(check.robot_ok)} of the path inside the robot's reach "
        "and limits",
        f"  subject's arm   {_share(check.arm_ok)} of the path inside the arm's comfortable reach",
    ]
    if check.reachable.any():
        lines += [
            "",
            "Joint-angle ranges over the reachable path",
            _range_line("  shoulder (ISB)", check.range_of(check.isb_angles_rad[:, 0])),
            _range_line("  elbow (ISB)", check.range_of(check.isb_angles_rad[:, 1])),
            _range_line("  robot joint 1", check.range_of(check.robot_angles_rad[:, 0])),
            _range_line("  robot joint 2", check.range_of(check.robot_angles_rad[:, 1])),
        ]
    lines += ["", "Result: " + ("ready to run." if check.ok else "refused.")]
    lines += [f"  {problem}" for problem in check.problems]
    return "\n".join(lines)


def _share(mask) -> str:
    return f"{100.0 * mask.mean():5.1f} %"


def _range_line(label: str, bounds: tuple[float, float]) -> str:
    low, high = (math.degrees(b) for b in bounds)
    return f"{label:<16}{low:7.1f}° to {high:6.1f}°  (range {high - low:.1f}°)"
