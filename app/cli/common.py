"""What every command group shares: the exit codes, the one-line error, the parser that
prints it, the progress bar, the data folder's registry, and figures as plain columns.

Every command validates its input through the same objects the window uses, and
every error is one clear line on stderr with exit code 2 — never a traceback.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from app.records.datadir import DataDir, locate_data_dir
from app.records.registry import Registry

EXIT_OK = 0
EXIT_BAD_INPUT = 2


class CommandError(Exception):
    """A command failed for a reason the user can fix; the message is the one line shown."""


class Parser(argparse.ArgumentParser):
    """argparse with one-line errors that point to --help."""

    def error(self, message: str) -> None:
        sys.stderr.write(f"{self.prog}: error: {message} (see {self.prog} --help)\n")
        raise SystemExit(EXIT_BAD_INPUT)


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


def registry_for(args: argparse.Namespace) -> Registry:
    """The registry of the data folder: `--data-dir`, else REHAB_DATA_DIR, the setting
    or the default (app.records.datadir.locate_data_dir)."""
    if getattr(args, "data_dir", None):
        return Registry(DataDir(absolute(args.data_dir), "command line"))
    return Registry(locate_data_dir())


SQLITE_INT_MAX = 2**63 - 1


def record_id(text: str) -> int:
    """An argparse type for a registry id: a whole number from 1 to SQLite's largest."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"invalid int value: {text!r} (a trial's id is a "
                                         "whole number; `rehab trials CODE` lists them)") from None
    if not 1 <= value <= SQLITE_INT_MAX:
        raise argparse.ArgumentTypeError(f"{text} is not a trial id: ids are whole numbers "
                                         "from 1 (`rehab trials CODE` lists them)")
    return value


def absolute(text: str) -> Path:
    """A path typed on the command line, with ~ expanded, made absolute."""
    return Path(text).expanduser().resolve()


def finite(value) -> bool:
    return isinstance(value, int | float) and math.isfinite(value)


def mm(value) -> str:
    """Metres as millimetres with one decimal; '–' where undefined."""
    return f"{1000 * value:.1f}" if finite(value) else "–"


def num(value) -> str:
    """A figure with one decimal; '–' where undefined."""
    return f"{value:.1f}" if finite(value) else "–"
