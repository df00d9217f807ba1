"""Does the assistance keep a patient working? A learning, slacking virtual patient over
a course of trials under each mode, and the feedforward the robot learns.

    .venv/bin/python bench/slacking.py [--trials N] [--plot FILE.png]

1. For the weak and the healthy virtual patient, `--trials` (default 20) headless trials
   of the thesis D with the trial-to-trial adaptation of device.sim.learning, under the
   as-needed mode with each trial taking the console's proposal made after the one before
   (app.trials.progression: the scheme whole), under the as-needed mode with the settings
   fixed, and under the thesis mode (a stiff tracker, fixed full assistance): the share
   of the patient's capability used in each trial, the error the patient felt, the
   robot's share of the work, and for the course with proposals the settings each trial
   ran with.
2. The passive patient's learned feedforward (N along the path) in each bin at the end of
   each repetition of one as-needed trial.

`--plot` also draws both into one PNG. Figures only; no assertion.
"""

from __future__ import annotations

import argparse

import numpy as np

from app.trials.adaptation import run_course
from app.trials.headless import simulate
from core.trial import THESIS_SUBJECT
from device.sim.learning import TrialToTrialAdaptation

COURSES = (("as-needed", True), ("as-needed", False), ("thesis", False))


def course_label(mode: str, follow: bool) -> str:
    return f"{mode}, {'proposals accepted' if follow else 'settings fixed'}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--trials", type=int, default=20)
    parser.add_argument("--plot", help="also write the curves to this PNG")
    args = parser.parse_args()
    rule = TrialToTrialAdaptation()
    print(f"adaptation: retention {rule.retention}, learning {rule.learning}, felt error "
          f"{1000 * rule.felt_error_m:g} mm; realistic plant, seed 0")
    curves = {}
    for patient in ("weak", "healthy"):
        for mode, follow in COURSES:
            course = run_course(THESIS_SUBJECT.replace(assist=mode), patient=patient,
                                trials=args.trials, adaptation=rule,
                                follow_proposals=follow)
            label = course_label(mode, follow)
            curves[(patient, label)] = course
            print(f"{patient}, {label}")
            print("  share of capability:  " + " ".join(f"{t.share:.2f}" for t in course))
            print("  felt error mm:        "
                  + " ".join(f"{1000 * t.felt_error_m:.1f}" for t in course))
            print("  robot's work share %: "
                  + " ".join(f"{100 * t.robot_work_share:.0f}" for t in course))
            if follow:
                print("  assistance %:         "
                      + " ".join(f"{100 * t.assistance_level:.0f}" for t in course))
                print("  s per traversal:      "
                      + " ".join(f"{t.duration_s:.2f}" for t in course))
                print("  led %:                "
                      + " ".join(f"{t.led_pct:.0f}" for t in course))
    trial = simulate(THESIS_SUBJECT.replace(assist="as-needed"), patient="passive")
    history = trial.feedforward_N
    np.set_printoptions(precision=2, suppress=True, linewidth=160)
    print("\npassive patient, learned feedforward (N) per bin at the end of each repetition:")
    for rep, row in enumerate(history):
        print(f"  repetition {rep + 1}: {row}")
    if args.plot:
        plot(curves, history, args.plot)
        print(f"plot: {args.plot}")


def plot(curves, history, path: str) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4))
    styles = {course_label(m, f): s for (m, f), s in zip(COURSES, ("-o", ":^", "--s"), strict=True)}
    for (patient, label), course in curves.items():
        left.plot(range(1, len(course) + 1), [t.share for t in course], styles[label],
                  markersize=3, color="tab:red" if patient == "weak" else "tab:blue",
                  label=f"{patient}, {label}")
    left.axhline(0.8, color="grey", linewidth=0.8, linestyle="--")  # the goal
    left.set_xticks(range(1, len(next(iter(curves.values()))) + 1, 2))
    left.set(xlabel="trial", ylabel="share of capability used", ylim=(0, 1.05),
             title="A learning, slacking virtual patient")
    left.legend(fontsize=7)
    bins = history.shape[1]
    for rep, row in enumerate(history):
        right.plot((np.arange(bins) + 0.5) / bins * 100, row, label=f"repetition {rep + 1}")
    right.set(xlabel="% of one repetition of the D", ylabel="learned force along the path (N)",
              title="Passive patient: learned feedforward")
    right.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)


if __name__ == "__main__":
    main()
