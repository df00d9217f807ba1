"""The weak virtual patient's flexion synergy on the battery's circle and on the thesis's D
(issue 31): circle ratio (both ways' mean, then each way) and shoulder–elbow joint
independence of the circle task (healthy, weak, passive; trial 1 of the task holds the task's
figures), then the weak patient's D with the as-needed assistance (one lap, realistic plant):
directional performance, the time the patient led (the as-needed help off), the robot's
share of the positive work and the RMS error.

    .venv/bin/python bench/synergy.py [--circle-seeds 7 8 9] [--d-seeds 1 2 3 4]
        [--kinds healthy weak passive] [--others] [--option NAME=VALUE ...]

`--option` sets the weak patient's options (device.sim.patients.make_patient), e.g.
`--option selectivity_loss=0` (the loss of selective joint control: 0.5 by default for the
weak kind) or `--option synergy=0.3` (the plan's coupling). `--others` adds what else the
option moves: the circle's SPARC, the reaching task's speed maxima, SPARC, reaches with no
movement end and initial direction error (seed 5, as tests/app/assessments/
test_reaching_task.py), the isometric strength task's directions at the line (seed 7) and,
on the D with the thesis's full assistance (5 laps, seed 0, no trial-to-trial variation),
the patient's and the robot's work. Figures only; no assertion; docs/assessments.md (The
virtual patients' circles) holds what it printed.
"""

from __future__ import annotations

import argparse
import ast


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--circle-seeds", nargs="*", type=int, default=[7, 8, 9])
    parser.add_argument("--d-seeds", nargs="*", type=int, default=[1, 2, 3, 4])
    parser.add_argument("--kinds", nargs="+", default=["healthy", "weak", "passive"])
    parser.add_argument("--others", action="store_true",
                        help="also the figures the option moves elsewhere")
    parser.add_argument("--option", action="append", default=[],
                        help="NAME=VALUE, an option of the weak patient")
    args = parser.parse_args()
    options = {}
    for item in args.option:
        name, _, value = item.partition("=")
        options[name] = ast.literal_eval(value)

    from app.assessments.runner import run_task
    from app.trials.analysis import analyse
    from app.trials.headless import simulate
    from core.trial import THESIS_SUBJECT

    print("weak patient's options:", options or "defaults")
    if args.circle_seeds:
        print(f"{'circle':<8}{'seed':>5}{'ratio':>8}{'ratio cw/ccw':>15}{'indep.':>8}"
              f"{'speed m/s':>10}" + (f"{'SPARC':>8}" if args.others else ""))
    for kind in args.kinds:
        for seed in args.circle_seeds:
            own = options if kind == "weak" else None
            f = run_task("circle", kind, seed=seed, in_memory=True,
                         patient_options=own)[0].metrics
            print(f"{kind:<8}{seed:>5}{f['circle_ratio']:8.3f}"
                  f"{f['circle_ratio_cw']:8.3f}/{f['circle_ratio_ccw']:.3f}"
                  f"{f['circle_joint_independence']:8.3f}{f['circle_mean_speed_m_s']:10.4f}"
                  + (f"{f['circle_sparc']:8.3f}" if args.others else ""))
    if args.d_seeds:
        print(f"\nD, as-needed, 1 lap, weak\n{'seed':>5}{'dir %':>8}{'led %':>8}"
              f"{'robot share':>12}{'RMSE x/y mm':>14}{'status':>10}")
    for seed in args.d_seeds:
        params = THESIS_SUBJECT.replace(assist="as-needed", repetitions=1)
        trial = simulate(params, patient="weak", seed=seed, patient_options=options or None)
        channels = {n: trial.records[n] for n in trial.records.dtype.names}
        m = analyse(channels, params).metrics
        print(f"{seed:>5}{m.directional_performance_pct:8.1f}{m.led_pct:8.1f}"
              f"{m.robot_work_share:12.2f}{1000 * m.rmse_x_m:8.2f}/{1000 * m.rmse_y_m:.2f}"
              f"{trial.status:>10}")
    if args.others:
        others(args.kinds, options)


def others(kinds: list[str], options: dict) -> None:
    """What else the weak patient's options move (the module notes, `--others`)."""
    from app.assessments.runner import run_task
    from app.trials.analysis import analyse
    from app.trials.headless import simulate
    from core.trial import THESIS_SUBJECT

    print(f"\n{'reaching':<9}{'maxima':>8}{'SPARC':>8}{'no end':>8}{'dir. err. rad':>14}"
          f"{'strength: at the line':>23}")
    for kind in kinds:
        own = options if kind == "weak" else None
        r = run_task("reaching", kind, seed=5, in_memory=True, patient_options=own)[0].figures
        s = run_task("strength", kind, seed=7, in_memory=True, patient_options=own)[0].figures
        print(f"{kind:<9}{r['vgr_speed_maxima_count']:8.2f}{r['vgr_sparc']:8.3f}"
              f"{r['vgr_no_movement_end_count']:8.0f}{r['vgr_initial_direction_error_rad']:14.3f}"
              f"{s['strength_at_limit_count']:17.0f} of 8")
    params = THESIS_SUBJECT.replace(assist="thesis")
    trial = simulate(params, patient="weak", seed=0,
                     patient_options={"variability": 0.0, **options})
    m = analyse({n: trial.records[n] for n in trial.records.dtype.names}, params).metrics
    print(f"\nD, thesis's assistance, weak: the patient's work {m.patient_work_J:+.2f} J, the "
          f"robot's {m.robot_work_J:+.2f} J, its share {m.robot_work_share:.2f}")


if __name__ == "__main__":
    main()
