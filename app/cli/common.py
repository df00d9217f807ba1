"""What every command group shares: the exit codes, the one-line error, the parser that
prints it, the progress bar, the data folder's registry, and figures as plain columns.

Every command validates its input through the same objects the window uses, and
every error is one clear line on stderr with exit code 2 — never a traceback.
"""

from __future__ import annotations

import argparse
import math
import re
import sys
from pathlib import Path

from app.errors import AppError
from app.records.datadir import CODE_PATTERN, DataDir, locate_data_dir
from app.records.registry import Registry, open_registry
from app.records.safewrite import check_output
from app.reports.metrics_table import number_text
from device.safeinput import check_file, check_folder
from device.safewrite import folded, os_reason, shown

EXIT_OK = 0
EXIT_BAD_INPUT = 2


class CommandError(Exception):
    """A command failed for a reason the user can fix; the message is the one line shown."""


_NOT_A_NUMBER = re.compile(r"argument (?P<option>\S+?): invalid (?P<kind>int|float) value: "
                           r"(?P<value>'[^']*')")
"""argparse's refusal of a value its type= int or float cannot read."""
SHORT_HELP = 60
"""A help this long or shorter (a unit: 'kg', 'shoulder to elbow, m') is said with a value
it cannot read."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors that point to --help."""

    def error(self, message: str) -> None:
        sys.stderr.write(f"{self.prog}: error: {folded(self._said(message))} "
                         f"(see {self.prog} --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)

    def _said(self, message: str) -> str:
        """'argument --body-mass: invalid float value: '70kg'' as '--body-mass '70kg' is
        not a number (kg)': what was wrong, and the option's unit when its help is short."""
        wrong = _NOT_A_NUMBER.fullmatch(message)
        if wrong is None:
            return message
        option = wrong["option"].split("/")[-1]
        number = "a whole number" if wrong["kind"] == "int" else "a number"
        action = self._option_string_actions.get(option)
        unit = self._get_formatter()._expand_help(action) if action and action.help else ""
        unit = f" ({unit})" if unit and len(unit) <= SHORT_HELP else ""
        return f"{option} {wrong['value']} is not {number}{unit}"


def subcommands(parser: argparse.ArgumentParser, *, dest: str = "action",
                metavar: str = "action", required: bool = True):
    """A command's actions (`rehab COMMAND ACTION …`): the one chosen in args.`dest`, each
    parser of the command's own class (Parser: one-line errors), one required unless
    said (a command that does something without one, as `rehab patients`)."""
    return parser.add_subparsers(dest=dest, metavar=metavar, required=required,
                                 parser_class=type(parser))


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


def progress_bar(label: str) -> ProgressBar | None:
    """A progress bar when stderr is a terminal; None when it is a file or a pipe."""
    return ProgressBar(label) if sys.stderr.isatty() else None


def data_dir_for(args: argparse.Namespace) -> DataDir:
    """The data folder: `--data-dir`, else REHAB_DATA_DIR, the setting or the default
    (app.records.datadir.locate_data_dir); nothing is created here."""
    if getattr(args, "data_dir", None) is not None:
        if not args.data_dir.strip():
            raise CommandError("--data-dir is empty: give the data folder")
        return DataDir(absolute(args.data_dir), "command line")
    return locate_data_dir()


def registry_for(args: argparse.Namespace, *, create: bool = False) -> Registry:
    """The registry this console uses (app.records.registry.open_registry: the registry URL
    file's, else the data folder's, data_dir_for). Only `create` (`rehab patients add`)
    starts a SQLite registry where there is none, in a new or empty folder; every other
    command refuses a missing one in one line saying what the folder holds, and creates
    nothing. A server's registry is created by its owner (`rehab db upgrade`)."""
    return open_registry(data_dir_for(args), create=create)


SQLITE_INT_MAX = 2**63 - 1


def record_id(text: str) -> int:
    """An argparse type for a registry id: a whole number from 1 to SQLite's largest."""
    stripped = text.strip()
    if not (stripped.isascii() and stripped.lstrip("+-").isdigit()):
        raise argparse.ArgumentTypeError(f"invalid int value: {shown(text)!r} (a trial's id is "
                                         "a whole number; `rehab trials CODE` lists them)")
    # a digit string of thousands of digits is refused before int() is asked to read it
    value = int(stripped) if len(stripped) <= 20 else SQLITE_INT_MAX + 1
    if not 1 <= value <= SQLITE_INT_MAX:
        raise argparse.ArgumentTypeError(f"{shown(text)} is not a trial id: ids are whole numbers "
                                         "from 1 (`rehab trials CODE` lists them)")
    return value


def absolute(text: str) -> Path:
    """A path typed on the command line, with ~ expanded, made absolute (links resolved);
    what the system refuses (a link loop, a name too long) is one line."""
    try:
        return Path(text).expanduser().resolve()
    except (OSError, RuntimeError, ValueError, RecursionError) as exc:
        reason = "a symbolic link loops back on itself on the way to it" if isinstance(
            exc, RuntimeError) and "loop" in str(exc).lower() else os_reason(exc)
        raise CommandError(f"{shown(text)}: {reason}; give another path") from None


def output_path(args: argparse.Namespace, text: str, *, overwrite: bool = False,
                inputs=(), suffixes: tuple[str, ...] = (), what: str = "--output") -> Path:
    """A file the command is to write, checked before any work is done: never over a file
    without --overwrite, never anything a data folder owns, never one of the command's
    `inputs` (app.records.safewrite.check_output); the write itself checks again."""
    if not text.strip():
        raise CommandError(f"{what} is empty: give a file name")
    if suffixes and not text.lower().endswith(suffixes):
        raise CommandError(f"{what} {shown(text)}: give a file name ending in "
                           f"{' or '.join(suffixes)}")
    return check_output(text, overwrite=overwrite, roots=data_roots(args), inputs=inputs,
                        what=what)


def input_file(text: str, what: str, *, max_bytes: int | None = None) -> Path:
    """A file the command is to read, checked before any reader opens it: a plain file (not
    a folder, a pipe, a device), no larger than `max_bytes` (device.safeinput)."""
    if not text.strip():
        raise CommandError(f"{what} is empty: give a file")
    return check_file(absolute(text), what=what, max_bytes=max_bytes)


def input_folder(text: str, what: str) -> Path:
    if not text.strip():
        raise CommandError(f"{what} is empty: give a folder")
    return check_folder(absolute(text), what=what)


def trial_id_or_none(text: str) -> int | None:
    """The registry id `text` names (ASCII digits only: '²' is a digit to str.isdigit), or
    None when it is not digits (then it is a path); an id out of range is refused."""
    text = text.strip()
    if not (text.isascii() and text.isdigit()):
        return None
    if len(text) > 19 or not 1 <= int(text) <= SQLITE_INT_MAX:
        raise CommandError(f"{shown(text)} is not a trial id: ids are whole numbers from 1 to "
                           f"{SQLITE_INT_MAX} (`rehab trials CODE` lists them)")
    return int(text)


def data_roots(args: argparse.Namespace) -> tuple[Path, ...]:
    """The command's data folder, when it can be told, for the outputs' checks."""
    try:
        return (data_dir_for(args).root,)
    except (AppError, CommandError):
        return ()


def finite(value) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


def mm(value) -> str:
    """Metres as millimetres with one decimal; '–' where undefined."""
    return f"{1000 * value:.1f}" if finite(value) else "–"


def counted(n: int, noun: str) -> str:
    """'1 cycle', '1,000 cycles': a count and its noun, plural but for one."""
    return f"{n:,} {noun}{'' if n == 1 else 's'}"


def typed_code(code: str, what: str = "the code") -> str:
    """`code` when it is a patient code, else the one line that says what one is. The text
    is not repeated: a name typed where a code goes is not echoed (app.records.datadir.
    check_code), and text the registry cannot look up (invalid UTF-8 made text) is refused
    before it is asked."""
    if not CODE_PATTERN.fullmatch(code):
        raise CommandError(f"{what} is not a patient code: a code is 'P' and 6 characters of "
                           "0-9 and A-Z (see `rehab patients`)")
    return code


def num(value) -> str:
    """A figure with one decimal; '–' where undefined; one that rounds to zero reads 0.0,
    never "-0.0" (`rehab progress` said a transparent trial's help was "-0.0 J")."""
    return number_text(value, 1) if finite(value) else "–"


def rewritten_trial(args: argparse.Namespace, text: str, path: Path, what: str):
    """A context for a command that writes into the trial `text` names (its id, or its file
    `path`): when the trial is registered, its file's checksum is recorded again after the
    write (app.trials.rewrite); a file of no registered trial is written as it is."""
    import contextlib

    from app.records.registry import has_registry
    from app.trials.rewrite import rewriting, rewriting_files

    number = trial_id_or_none(text)
    if number is not None:
        return rewriting(registry_for(args), number, what)
    data_dir = data_dir_for(args)
    if not (Path(path).resolve().is_relative_to(data_dir.trials_dir.resolve())
            and has_registry(data_dir)):
        return contextlib.nullcontext()
    return rewriting_files(registry_for(args), [path], what)


def next_session(registry, code: str) -> int:
    """The number a new session of the patient's takes (`--new-session`): the next after
    their latest, today's or not."""
    suggested = registry.suggest_registration(code)
    return suggested.session_number + (0 if suggested.new_session else 1)
