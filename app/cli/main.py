"""The headless command line: `rehab <command> [options]`: the parser and the dispatch.

Each command group is a module of its own (app.cli.check, .run, .records,
.reports, .exports, .learn) that adds its subcommands and runs them; this module puts
them in one parser, in the order `rehab --help` lists them, and turns every
expected failure into one line on stderr with exit code 2 — never a traceback.
The `gui` command is added by `ui.launcher`, which owns the only entry point.
"""

from __future__ import annotations

import argparse
import contextlib
import logging
import os
import sys
from collections.abc import Sequence

from app.cli.assess import add_assess_commands
from app.cli.check import add_check_command
from app.cli.clinical import add_clinical_commands
from app.cli.common import EXIT_BAD_INPUT, CommandError, Parser, subcommands
from app.cli.db import add_db_commands
from app.cli.emg import add_emg_commands
from app.cli.exports import add_export_command
from app.cli.gains import add_gains_command
from app.cli.hardware import add_hardware_command
from app.cli.learn import add_learn_commands
from app.cli.models import add_models_command
from app.cli.norms import add_norms_commands
from app.cli.plans import add_plan_commands
from app.cli.pose import add_pose_command
from app.cli.reanalyse import add_reanalyse_command
from app.cli.records import add_patient_commands, add_trials_command
from app.cli.reports import (
    add_progress_command,
    add_report_command,
    add_session_report_command,
)
from app.cli.run import add_run_command
from app.cli.study import add_study_commands
from app.errors import AppError
from core.errors import CoreError
from device.errors import DeviceError
from device.safewrite import folded, os_reason, shown

log = logging.getLogger(__name__)

# Each adds its subcommands to the parser's `commands`, in the order of the help.
COMMAND_GROUPS = (
    add_check_command,
    add_run_command,
    add_patient_commands,
    add_trials_command,
    add_clinical_commands,
    add_progress_command,
    add_report_command,
    add_session_report_command,
    add_export_command,
    add_pose_command,
    add_gains_command,
    add_learn_commands,
    add_emg_commands,
    add_models_command,
    add_plan_commands,
    add_norms_commands,
    add_assess_commands,
    add_study_commands,
    add_reanalyse_command,
    add_db_commands,
    add_hardware_command,
)


def build_parser(prog: str = "rehab") -> tuple[Parser, argparse._SubParsersAction]:
    parser = Parser(
        prog=prog,
        description="Clinical console for the planar upper-limb rehabilitation robot.",
    )
    parser.add_argument("--data-dir", help=DATA_DIR_HELP)
    commands = subcommands(parser, dest="command", metavar="command", required=False)
    for add_commands in COMMAND_GROUPS:
        add_commands(commands)
    return parser, commands


def run(parser: Parser, argv: Sequence[str] | None, default: str) -> int:
    """Parse and run one command, turning every expected failure into one line and exit 2."""
    argv = list(sys.argv[1:] if argv is None else argv)
    names = _command_names(parser)
    options_only = not argv or (argv[0].startswith("-") and argv[0] not in ("-h", "--help"))
    if options_only and not any(a in names for a in argv):
        # no command given (`rehab`, `rehab --data-dir D`): the entry point's default
        argv.insert(0, default)
    _data_dir_everywhere(parser)
    # a path typed in bytes that are not UTF-8 reaches Python as surrogates: printed back
    # as the same bytes, not as an encoding error
    for stream in (sys.stdout, sys.stderr):
        with contextlib.suppress(AttributeError, ValueError):
            stream.reconfigure(errors="surrogateescape")
    args, unknown = parser.parse_known_args(argv)
    if unknown:
        # said by the command's own parser, whose help lists the options (the top one's
        # lists only the commands)
        _command_parser(parser, args).error(f"unrecognized arguments: {' '.join(unknown)}")
    # whatever the shell's umask: every file the console writes (trial files, the registry,
    # reports, exports, settings, logs) is its user's only (README, Where the data goes);
    # the writers apply the modes themselves too (device.safewrite)
    os.umask(0o077)
    command = " ".join(filter(None, (args.command, getattr(args, "action", None),
                                     getattr(args, "emg_command", None))))
    with _warnings_said_on_success(parser, command) as outcome:
        outcome.code = _run_command(parser, args, command)
    return outcome.code


class _Outcome:
    code = EXIT_BAD_INPUT


class _Warnings(logging.Handler):
    """The log's warnings of one command, each on one line."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        with contextlib.suppress(Exception):
            self.lines.append(folded(record.getMessage()))


@contextlib.contextmanager
def _warnings_said_on_success(parser, command: str):
    """The log's warnings printed after a command that succeeded, one line each; after a
    refusal its one line is all that is said (Python would otherwise print them, and
    tracebacks, on stderr by itself). Where logging is set up already (the window, the
    tests), it is left alone."""
    root = logging.getLogger()
    outcome = _Outcome()
    if root.handlers:
        yield outcome
        return
    said = _Warnings()
    root.addHandler(said)
    try:
        yield outcome
    finally:
        root.removeHandler(said)
    if outcome.code == 0:
        for line in said.lines:
            sys.stderr.write(f"{parser.prog} {command}: warning: {line}\n")


def _run_command(parser, args: argparse.Namespace, command: str) -> int:
    try:
        return args.func(args)
    except (CommandError, CoreError, AppError, DeviceError) as exc:
        return refuse(parser, command, one_line(exc))
    except BrokenPipeError:
        # the reader went away (`rehab … | head`): what it wanted it has; the rest is not
        # an error, and Python must not print one at exit when it flushes stdout
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    except OSError as exc:  # what the system said of a file the command was given
        where = f"{shown(exc.filename)}: " if exc.filename else ""
        return refuse(parser, command, f"{where}{os_reason(exc)}")
    except MemoryError:
        return refuse(parser, command, "the input is too large to hold in memory: check the "
                                       "files given are the right ones")
    except RecursionError:
        return refuse(parser, command, "the input is nested too deeply to read")
    except KeyboardInterrupt as exc:
        notes = "".join(f" ({folded(note)})" for note in getattr(exc, "__notes__", ()))
        sys.stderr.write(f"{parser.prog} {command}: interrupted{notes}\n")
        return 130
    except Exception as exc:  # a bug: one line here, the traceback to the log if one is kept
        log.exception("rehab %s failed", command)
        sys.stderr.write(f"{parser.prog} {command}: internal error ({type(exc).__name__}: "
                         f"{one_line(exc)}); this is a bug: please report it with the "
                         "command\n")
        return EXIT_INTERNAL


EXIT_INTERNAL = 70
"""A failure no input should cause (sysexits' EX_SOFTWARE): the fuzz test counts it."""


def one_line(exc: BaseException) -> str:
    """The exception's message on one line, with the notes added to it (app.trials.registered
    says there what became of a refused trial)."""
    notes = [folded(note) for note in getattr(exc, "__notes__", ())]
    text = folded(exc) or type(exc).__name__
    return text + "".join(f" ({note})" for note in notes if note)


def refuse(parser: argparse.ArgumentParser, command: str, message: str) -> int:
    sys.stderr.write(f"{parser.prog} {command}: error: {message}\n")
    return EXIT_BAD_INPUT


DATA_DIR_HELP = "data folder (default: REHAB_DATA_DIR, the setting, or the user data folder)"


def _command_parser(parser: argparse.ArgumentParser,
                    args: argparse.Namespace) -> argparse.ArgumentParser:
    """The parser of the command (and action) the arguments chose: `rehab emg show`'s."""
    while True:
        chosen = next((action.choices.get(getattr(args, action.dest, None))
                       for action in parser._actions
                       if isinstance(action, argparse._SubParsersAction)), None)
        if chosen is None:
            return parser
        parser = chosen


def _command_names(parser: argparse.ArgumentParser) -> set[str]:
    return {name for action in parser._actions
            if isinstance(action, argparse._SubParsersAction) for name in action.choices}


def _data_dir_everywhere(parser: argparse.ArgumentParser) -> None:
    """`--data-dir` before the command, after it, or after its action (`rehab patients add
    --data-dir D`): every command and action takes it, and the one given wins."""
    for action in parser._actions:
        if not isinstance(action, argparse._SubParsersAction):
            continue
        for sub in action.choices.values():
            if not any("--data-dir" in a.option_strings for a in sub._actions):
                sub.add_argument("--data-dir", default=argparse.SUPPRESS, help=DATA_DIR_HELP)
            _data_dir_everywhere(sub)


def main(argv: Sequence[str] | None = None) -> int:
    """Headless entry (no window): the default command is `check`."""
    parser, _ = build_parser()
    return run(parser, argv, default="check")
