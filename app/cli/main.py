"""The headless command line: `rehab <command> [options]`.

Every command validates its input through the same objects the window uses, and
every error is one clear line on stderr with exit code 2 — never a traceback.
The `gui` command is added by `ui.launcher`, which owns the only entry point.
"""

from __future__ import annotations

import argparse
import math
import sys
from collections.abc import Callable, Sequence

from app.errors import AppError
from core.errors import CoreError
from core.trajectory import SHAPES, TIMINGS
from core.trial import (
    CONTROLLERS,
    SIDES,
    THESIS_AS_PRINTED,
    THESIS_SUBJECT,
    TrialParameters,
    check_trial,
)
from device.errors import DeviceError

EXIT_OK = 0
EXIT_BAD_INPUT = 2


class CommandError(Exception):
    """A command failed for a reason the user can fix; the message is the one line shown."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors that point to --help."""

    def error(self, message: str) -> None:
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)


def add_trial_options(parser: argparse.ArgumentParser) -> None:
    """Options that define a trial. Lengths in metres; angles in degrees as a therapist
    reads them; defaults are the thesis's experiment with the shoulder as we read it."""
    d = THESIS_SUBJECT
    group = parser.add_argument_group("trial (lengths in m, angles in degrees)")
    group.add_argument("--shape", "--trajectory", choices=SHAPES, default=d.shape,
                       help="exercise path (default d)")
    group.add_argument("--centre", nargs=2, type=float, metavar=("X", "Y"), default=d.centre_m,
                       help="D: centre of its straight line; circle/targets/figure8: centre; "
                            "reach: start point (default -0.30 0.30)")
    group.add_argument("--radius", type=float, default=d.radius_m,
                       help="radius; for a reach, half its length (default 0.10)")
    group.add_argument("--duration", type=float, default=d.duration_s,
                       help="seconds per traversal (default 4)")
    group.add_argument("--repetitions", type=int, default=d.repetitions,
                       help="traversals (default 5)")
    group.add_argument("--timing", choices=TIMINGS, default=d.timing,
                       help="constant speed as in the thesis, or minimum jerk per segment")
    group.add_argument("--counter-clockwise", action="store_true", help="reverse the direction")
    group.add_argument("--targets", type=int, default=d.n_targets, dest="n_targets",
                       help="number of targets for --shape targets (default 8)")
    group.add_argument("--shoulder", nargs=2, type=float, metavar=("X", "Y"),
                       default=d.shoulder_m, help="subject's shoulder (default -0.12 0.73)")
    group.add_argument("--body-mass", type=float, default=d.body_mass_kg,
                       help="body mass in kg (default 91)")
    group.add_argument("--upper-arm", type=float, default=d.upper_arm_m,
                       help="shoulder to elbow in m (default 0.3048)")
    group.add_argument("--forearm", type=float, default=d.forearm_m,
                       help="elbow to wrist in m (default 0.3048)")
    group.add_argument("--side", choices=SIDES, default=d.side, help="arm in use")
    group.add_argument("--tolerance", type=float, default=math.degrees(d.tolerance_rad),
                       help="directional tolerance in degrees (default 20)")
    group.add_argument("--controller", choices=CONTROLLERS, default=d.controller)
    group.add_argument("--assistance", type=float, default=100 * d.assistance_level,
                       help="share of the subject's effort the robot gives way to, "
                            "0-100 %% (default 100, the thesis's scheme)")
    group.add_argument("--thesis-as-printed", action="store_true",
                       help="use section 3.6 exactly as printed (shoulder at +0.12 m: refused)")


def trial_from_args(args: argparse.Namespace) -> TrialParameters:
    """TrialParameters from parsed options; raises core.errors.ParameterError."""
    base = THESIS_AS_PRINTED if args.thesis_as_printed else THESIS_SUBJECT
    changes = {
        "shape": args.shape,
        "centre_m": tuple(args.centre),
        "radius_m": args.radius,
        "duration_s": args.duration,
        "repetitions": args.repetitions,
        "timing": args.timing,
        "clockwise": not args.counter_clockwise,
        "n_targets": args.n_targets,
        "body_mass_kg": args.body_mass,
        "upper_arm_m": args.upper_arm,
        "forearm_m": args.forearm,
        "side": args.side,
        "tolerance_rad": math.radians(args.tolerance),
        "controller": args.controller,
        "assistance_level": args.assistance / 100.0,
    }
    if not args.thesis_as_printed:
        changes["shoulder_m"] = tuple(args.shoulder)
    return base.replace(**changes)


def cmd_run(args: argparse.Namespace) -> int:
    """Simulate a whole trial headless, write its file and print its metrics."""
    import datetime
    from pathlib import Path

    from app.reports.metrics_table import format_metrics
    from app.trials.headless import save, simulate

    params = trial_from_args(args)
    begun = None
    if args.code:
        from app.cli.records import registry_for

        registry = registry_for(args)
        patient = registry.patient(args.code)
        params = params.replace(**patient.trial_overrides())
        if args.output:
            raise CommandError("--output cannot be used with --code: a registered trial is "
                               "written to the patient's folder in the data folder")
        begun = registry.begin_trial(args.code, params, backend=f"simulator ({args.patient})",
                                     patient_kind=args.patient)
        path = begun.path
    elif args.output:
        path = Path(args.output).expanduser().resolve()
    else:
        from app.records.datadir import locate_data_dir

        stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
        folder = locate_data_dir().ensure("trials", "simulated")
        path = folder / f"SIM_{args.patient}_{stamp}.h5"
    if path.exists():
        raise CommandError(f"{path} already exists; give another --output")
    bar = ProgressBar(f"simulating {params.repetitions} × {params.duration_s:g} s") \
        if sys.stderr.isatty() else None
    trial = simulate(params, patient=args.patient, seed=args.seed,
                     progress=bar.update if bar else None, engine=args.engine)
    if bar:
        bar.done()
    analysis = save(trial, path, subject_code=args.code or "SIM")
    if begun is not None:
        from app.trials.finalize import finalize_trial

        finalize_trial(registry, begun.trial_id, trial.status)
        print(f"Registered as patient {args.code}, session {begun.session_number}, "
              f"trial {begun.trial_number} (id {begun.trial_id})")
    loaded = f"; its kernels loaded in {trial.load_s:.2f} s first" if trial.load_s else ""
    print(f"Trial {trial.status}: {trial.simulated_s:.1f} s simulated in "
          f"{trial.elapsed_s:.2f} s ({trial.speed_vs_real_time:.0f}× real time, "
          f"{trial.engine} engine{loaded}), {args.patient} virtual patient, seed {args.seed}")
    print(f"File: {path}")
    print(format_metrics(analysis.metrics))
    for note in analysis.notes:
        print(f"  note: {note}")
    for event in trial.events:
        if event["kind"] == "fault":
            print(f"  fault at {event['time_s']:.3f} s: {event['message']}")
    return EXIT_OK


class ProgressBar:
    """A one-line progress bar on stderr for long commands."""

    def __init__(self, label: str, width: int = 30) -> None:
        self.label, self.width, self._shown = label, width, -1

    def update(self, fraction: float) -> None:
        filled = int(fraction * self.width)
        if filled != self._shown:
            self._shown = filled
            bar = "#" * filled + "." * (self.width - filled)
            sys.stderr.write(f"\r{self.label} [{bar}] {100 * fraction:3.0f} %")
            sys.stderr.flush()

    def done(self) -> None:
        self.update(1.0)
        sys.stderr.write("\n")


def cmd_check(args: argparse.Namespace) -> int:
    from app.reports.check import format_check

    check = check_trial(trial_from_args(args))
    print(format_check(check))
    if not check.ok:
        raise CommandError(check.problems[0])
    return EXIT_OK


Command = Callable[[argparse.Namespace], int]


def build_parser(prog: str = "rehab") -> tuple[Parser, argparse._SubParsersAction]:
    parser = Parser(
        prog=prog,
        description="Clinical console for the planar upper-limb rehabilitation robot.",
    )
    parser.add_argument("--data-dir", help="data folder (default: REHAB_DATA_DIR, the "
                                           "setting, or the user data folder)")
    commands = parser.add_subparsers(dest="command", metavar="command", parser_class=Parser)
    check = commands.add_parser(
        "check", help="check a trial's parameters and reachability for a subject",
        description="Check a trial: the subject's arm model, whether the robot and the arm can "
                    "reach the whole path, and the joint-angle ranges it asks for.",
    )
    add_trial_options(check)
    check.set_defaults(func=cmd_check)

    run_cmd = commands.add_parser(
        "run", help="simulate a whole trial headless, save it and print its metrics",
        description="Run a trial on the simulator with a virtual patient as fast as it goes, "
                    "write its trial file and print the metrics table.",
    )
    add_trial_options(run_cmd)
    from device.sim.patients import PATIENT_KINDS

    run_cmd.add_argument("--patient", choices=PATIENT_KINDS, default="healthy",
                         help="virtual patient (default healthy)")
    run_cmd.add_argument("--seed", type=int, default=0, help="random seed (default 0)")
    run_cmd.add_argument("--output", help="trial file to write (default: a new file in the "
                                          "data folder's trials/simulated)")
    run_cmd.add_argument("--code", help="register the trial for this patient (their body "
                                        "sizes replace the trial options')")
    run_cmd.add_argument("--engine", choices=("auto", "compiled", "python"), default="auto",
                         help="auto (default): compiled, handing faults to Python; python: "
                              "the reference implementation the live loop also uses")
    run_cmd.set_defaults(func=cmd_run)

    from app.cli.records import (
        add_export_command,
        add_patient_commands,
        add_report_command,
        add_trial_commands,
    )

    add_patient_commands(commands)
    add_trial_commands(commands)
    add_report_command(commands)
    add_export_command(commands)
    return parser, commands


def run(parser: Parser, argv: Sequence[str] | None, default: str) -> int:
    """Parse and run one command, turning every expected failure into one line and exit 2."""
    argv = list(sys.argv[1:] if argv is None else argv)
    if not argv or (argv[0].startswith("-") and argv[0] not in ("-h", "--help")):
        argv.insert(0, default)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (CommandError, CoreError, AppError, DeviceError) as exc:
        sys.stderr.write(f"{parser.prog} {args.command}: error: {exc}\n")
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        sys.stderr.write(f"{parser.prog} {args.command}: interrupted\n")
        return 130


def main(argv: Sequence[str] | None = None) -> int:
    """Headless entry (no window): the default command is `check`."""
    parser, _ = build_parser()
    return run(parser, argv, default="check")
