"""`rehab gains`: every gain a trial's `--gains` may change, with its default and range
(core.control.gains)."""

from __future__ import annotations

import argparse

from app.cli.common import EXIT_OK


def add_gains_command(commands) -> None:
    gains = commands.add_parser(
        "gains", help="list the controller's and the guidance's gains a trial may change",
        description="List every gain that `rehab run --gains` and the Parameters tab's "
                    "advanced part may change: its name, its default and its range.",
    )
    gains.set_defaults(func=cmd_gains)


def cmd_gains(args: argparse.Namespace) -> int:
    from core.control.gains import gain_rows

    rows = gain_rows()
    width = max(len(name) for name, *_ in rows)
    print("Change them with --gains \"group.name=value; …\" (a per-joint gain takes one "
          "number for both joints, or two: joint 1,joint 2).")
    for name, default, meaning, _ in rows:
        print(f"  {name:<{width}}  {default:>12}  {meaning}")
    return EXIT_OK
