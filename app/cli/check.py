"""`rehab check`: a trial's parameters and reachability for a subject, before any robot
moves (core.trial_check.check_trial, printed by app.reports.check). The default command of
the headless entry point (`app.cli.main.main`)."""

from __future__ import annotations

import argparse

from app.cli.common import EXIT_OK, CommandError
from app.cli.trial_options import add_trial_options, trial_from_args
from core.trial_check import check_trial


def add_check_command(commands) -> None:
    check = commands.add_parser(
        "check", help="check a trial's parameters and reachability for a subject",
        description="Check a trial: the subject's arm model, whether the robot and the arm can "
                    "reach the whole path, and the joint-angle ranges it asks for.",
    )
    add_trial_options(check)
    check.set_defaults(func=cmd_check)


def cmd_check(args: argparse.Namespace) -> int:
    from app.reports.check import format_check

    check = check_trial(trial_from_args(args))
    print(format_check(check))
    if not check.ok:
        raise CommandError(check.problems[0])
    return EXIT_OK
