"""The one entry point, `rehab`: the window by default, every headless command beside it.

Qt is imported only when the window starts, so the headless commands work on a
machine without a display, and the window explains a missing display in one
line instead of a Qt abort.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from collections.abc import Sequence

from app.cli.common import CommandError
from app.cli.main import build_parser, run

X_LIBRARIES = {"xcb-cursor": "libxcb-cursor0", "xcb-icccm": "libxcb-icccm4",
               "xcb-keysyms": "libxcb-keysyms1", "xkbcommon-x11": "libxkbcommon-x11-0"}
"""The libraries Qt's X platform plugin loads beyond a bare system's (Qt 6.5 and later
abort without xcb-cursor), by the Debian/Ubuntu package that has each."""


FONT_SCALE_RANGE = (0.75, 2.0)
"""ui.theme's range, checked here too so that a wrong --font-scale is refused by the
parser, in one line, before Qt is imported (the theme's own check is for the code)."""


def font_scale_arg(text: str) -> float:
    """An argparse type for --font-scale: a number within FONT_SCALE_RANGE."""
    low, high = FONT_SCALE_RANGE
    try:
        value = float(text)
    except ValueError:
        value = math.nan
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a text size: give a number from {low:g} to {high:g} "
            "(1 is the normal size)")
    return value


def _find_library(name: str) -> str | None:
    import ctypes.util

    return ctypes.util.find_library(name)


def display_problem(environ=os.environ, platform: str = sys.platform,
                    find_library=_find_library) -> str:
    """Why a window cannot open here, or '' if it can."""
    if platform != "linux":
        return ""
    chosen = environ.get("QT_QPA_PLATFORM", "").split(":")[0]
    if chosen in ("offscreen", "minimal", "vnc", "eglfs", "linuxfb"):
        return ""
    if environ.get("WAYLAND_DISPLAY") and chosen != "xcb":
        return ""
    if environ.get("DISPLAY"):
        missing = [package for name, package in X_LIBRARIES.items() if not find_library(name)]
        if not missing:
            return ""
        return (f"the X libraries the window needs are missing ({', '.join(missing)}), so "
                f"it cannot open. Install them (`sudo apt install {' '.join(missing)}`); the "
                "headless commands (`rehab check`, `rehab run`, …) work without them.")
    return (
        "no display found (neither DISPLAY nor WAYLAND_DISPLAY is set), so the window cannot "
        "open. Run it from a desktop session, or under a virtual display with "
        "`xvfb-run rehab gui`; the headless commands (`rehab check`, `rehab run`, …) work here."
    )


def cmd_gui(args) -> int:
    problem = display_problem()
    if problem:
        raise CommandError(problem)
    from ui.gui import run_gui

    return run_gui(font_scale=args.font_scale, lsl_outlet=args.lsl_outlet)


def main(argv: Sequence[str] | None = None) -> int:
    parser, commands = build_parser()
    gui = commands.add_parser("gui", help="the console's window (the default command)",
                              description="Open the therapist's console window.")
    gui.add_argument("--font-scale", type=font_scale_arg,
                     help="text size, 0.75-2 (default 1)")
    gui.add_argument("--lsl-outlet", action="store_true",
                     help="publish the robot's state and events on the Lab Streaming Layer "
                          "while trials run (streams rehab-robot, rehab-robot-events)")
    gui.set_defaults(func=cmd_gui)
    return run(parser, argv, default="gui")


if __name__ == "__main__":
    raise SystemExit(main())
