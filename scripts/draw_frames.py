"""Draw docs/frames.png: the robot's global frame, its workspace, the subject's arm and
the thesis's D, with the shoulder as printed and as we read it.

Run: .venv/bin/python scripts/draw_frames.py
"""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from core.robot import RobotModel
from core.trial import THESIS_AS_PRINTED, THESIS_SUBJECT
from core.trial_check import check_trial

OUT = Path(__file__).resolve().parent.parent / "docs" / "frames.png"


def main() -> None:
    robot = RobotModel()
    fig, ax = plt.subplots(figsize=(8.0, 9.0), dpi=110)

    # Robot workspace within its joint limits: sample a grid and keep what IK accepts.
    xs, ys = np.meshgrid(np.linspace(-0.75, 0.75, 301), np.linspace(-0.3, 0.8, 221))
    q1, q2 = robot.ik_terms(xs, ys)
    ok = ~np.isnan(q1)
    flat = ok.ravel()
    for i in np.flatnonzero(flat):
        if robot.limit_problem(q1.ravel()[i], q2.ravel()[i]):
            flat[i] = False
    ax.contourf(xs, ys, flat.reshape(xs.shape), levels=[0.5, 1.5], colors=["#dde8f3"])
    ax.plot([], [], color="#dde8f3", lw=8, label="robot workspace (within joint limits)")

    # The robot at the D's centre
    params = THESIS_SUBJECT
    q = robot.ik(params.centre_m)
    p2 = robot.l2_m * np.array([math.cos(q[1]), math.sin(q[1])])
    p1 = robot.l1_m * np.array([math.cos(q[0]), math.sin(q[0])])
    ee = robot.fk(q)
    ax.plot([0, p2[0], ee[0]], [0, p2[1], ee[1]], "-o", color="#1f4e79", lw=3, ms=4,
            label="robot links l2, l4 (θ_R2, θ_R1)")
    ax.plot([0, p1[0], p1[0] + p2[0]], [0, p1[1], p1[1] + p2[1]], "-", color="#6a8fb5", lw=2,
            label="links l1, l3 (parallelogram)")

    for trial, colour, name in (
        (THESIS_SUBJECT, "#0072b2", "shoulder as we read it (−0.12, 0.73) m"),
        (THESIS_AS_PRINTED, "#d55e00", "shoulder as printed (+0.12, 0.73) m"),
    ):
        arm = trial.arm()
        s = np.array([arm.shoulder_x_m, arm.shoulder_y_m])
        circle = plt.Circle(s, arm.reach_max_m, fill=False, ls="--", color=colour)
        ax.add_patch(circle)
        ax.plot(*s, "s", color=colour, ms=8, label=f"{name}; dashed: 0.61 m reach")

    check = check_trial(THESIS_AS_PRINTED)
    pts = check.points_m
    ax.plot(pts[:, 0], pts[:, 1], color="#009e73", lw=3, label="thesis D (line at x = −0.30 m)")
    bad = ~check.arm_ok
    ax.plot(pts[bad, 0], pts[bad, 1], ".", color="#d55e00", ms=4,
            label="beyond the printed shoulder's reach")

    # The arm (our reading) holding the handle at the D's centre
    arm = THESIS_SUBJECT.arm()
    ts, te = arm.ik_terms(*ee)
    elbow = arm.elbow_position(ts, te)
    ax.plot([arm.shoulder_x_m, elbow[0], ee[0]], [arm.shoulder_y_m, elbow[1], ee[1]], "-o",
            color="#cc79a7", lw=3, label="subject's right arm (θ_s, θ_e)")

    ax.annotate("", xy=(0.12, 0), xytext=(0, 0), arrowprops={"arrowstyle": "->", "lw": 2})
    ax.annotate("", xy=(0, 0.12), xytext=(0, 0), arrowprops={"arrowstyle": "->", "lw": 2})
    ax.text(0.13, -0.02, "x", fontsize=12)
    ax.text(-0.03, 0.13, "y", fontsize=12)
    ax.text(0.01, -0.05, "motor axes (origin)", fontsize=9)
    ax.text(-0.12, 0.78, "subject seated here, facing −y", fontsize=9, ha="center")
    ax.set_aspect("equal")
    ax.set_xlim(-0.75, 0.75)
    ax.set_ylim(-0.3, 0.85)
    ax.set_xlabel("x (m), global frame")
    ax.set_ylabel("y (m), global frame")
    ax.grid(True, lw=0.3)
    ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.08), ncol=2, fontsize=8)
    ax.set_title("Robot frame, workspace, subject's arm and the thesis's D")
    fig.tight_layout()
    fig.savefig(OUT)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
