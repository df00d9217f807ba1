"""Logging set-up: one log file per local day in <data dir>/logs, and warnings on stderr.

The files are named by their day from the start (`rehab-console-2024-05-01.log`)
and the handler moves to the next day's file at midnight, instead of the standard
library's rename-at-midnight: with two consoles (or a console and the loop
process) on one data folder, the second process to rotate would delete the
first one's renamed file (TimedRotatingFileHandler removes an existing target),
and on Windows the rename fails while the other process holds the file open.
Appending to a file named by the day needs no rename, so every process can
write to it. Files older than `keep_days` days are deleted when a day starts.

`setup_logging` is idempotent: calling it again with the same folder changes
nothing; with another folder it moves the file handler there.
"""

from __future__ import annotations

import datetime
import logging
import logging.handlers
import os
import re
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from app.records.datadir import LOGS, PRIVATE_FILE, DataDir, locate_data_dir

LOG_PREFIX = "rehab-console-"
LOG_SUFFIX = ".log"
KEEP_DAYS = 90
FILE_FORMAT = "%(asctime)s %(levelname)s %(name)s [%(process)d %(threadName)s] %(message)s"
DATE_FORMAT = "%Y-%m-%dT%H:%M:%S%z"
STDERR_FORMAT = "%(levelname)s: %(message)s"

_DAY_FILE = re.compile(re.escape(LOG_PREFIX) + r"(\d{4}-\d{2}-\d{2})" + re.escape(LOG_SUFFIX))
_lock = threading.Lock()
_installed: dict[str, logging.Handler] = {}


def log_file_for(folder: Path, when_s: float) -> Path:
    """The log file of the local day containing the time `when_s` (s since the epoch)."""
    day = datetime.date.fromtimestamp(when_s)
    return folder / f"{LOG_PREFIX}{day.isoformat()}{LOG_SUFFIX}"


class DailyFileHandler(logging.handlers.TimedRotatingFileHandler):
    """Appends to the current local day's file; at midnight, to the next day's.

    Reuses the base class's midnight arithmetic (DST included) but never renames
    (see the module's doc). `clock` is time.time; a test gives its own.
    """

    def __init__(self, folder: Path, keep_days: int = KEEP_DAYS,
                 clock: Callable[[], float] = time.time) -> None:
        self.folder = Path(folder)
        self.keep_days = keep_days
        self.clock = clock
        super().__init__(log_file_for(self.folder, clock()), when="midnight",
                         backupCount=0, encoding="utf-8")
        self.rolloverAt = self.computeRollover(int(clock()))
        self.prune()

    def _open(self):
        """The day's file, readable by its user only whatever the umask (a log names
        patients' codes and their trials' events): created 0600 (open() gave it the
        umask's mode until a chmod after), and one an earlier console left open closed
        again. A log is appended to all day by every process of the console, so it is
        not written whole through a temporary as the console's other files are
        (device.safewrite)."""
        fd = os.open(self.baseFilename, os.O_WRONLY | os.O_CREAT | os.O_APPEND
                     | getattr(os, "O_CLOEXEC", 0), PRIVATE_FILE)
        try:
            os.fchmod(fd, PRIVATE_FILE)
        except OSError:
            os.close(fd)
            raise
        return os.fdopen(fd, "a", encoding=self.encoding, errors=self.errors)

    def shouldRollover(self, record: logging.LogRecord) -> bool:
        return self.clock() >= self.rolloverAt

    def doRollover(self) -> None:
        if self.stream:
            self.stream.close()
            self.stream = None
        now = self.clock()
        self.baseFilename = str(log_file_for(self.folder, now).absolute())
        self.stream = self._open()
        self.rolloverAt = self.computeRollover(int(now))
        self.prune()

    def prune(self) -> list[Path]:
        """Delete this handler's day files older than keep_days; return them."""
        oldest = datetime.date.fromtimestamp(self.clock()) - datetime.timedelta(self.keep_days)
        deleted = []
        for path in self.folder.glob(f"{LOG_PREFIX}*{LOG_SUFFIX}"):
            match = _DAY_FILE.fullmatch(path.name)
            if not match:
                continue
            try:
                day = datetime.date.fromisoformat(match.group(1))
            except ValueError:
                continue
            if day < oldest:
                try:
                    path.unlink()
                except OSError:
                    continue  # another process pruned it, or it is held open: next day
                deleted.append(path)
        return deleted


def setup_logging(
    data_dir: DataDir | None = None,
    *,
    level: int = logging.INFO,
    stderr: bool = False,
    keep_days: int = KEEP_DAYS,
) -> Path:
    """Send the root logger's records at `level` and above to today's log file in
    <data dir>/logs (created if needed), and warnings to stderr when `stderr`
    (command-line use). Returns today's log file. Safe to call more than once."""
    data_dir = data_dir or locate_data_dir()
    folder = data_dir.ensure(LOGS)
    root = logging.getLogger()
    with _lock:
        current = _installed.get("file")
        if not (isinstance(current, DailyFileHandler) and current.folder == folder
                and current.keep_days == keep_days):
            _remove("file", root)
            handler = DailyFileHandler(folder, keep_days)
            handler.setFormatter(logging.Formatter(FILE_FORMAT, DATE_FORMAT))
            _add("file", handler, root)
        _installed["file"].setLevel(level)
        if stderr and "stderr" not in _installed:
            handler = logging.StreamHandler(sys.stderr)
            handler.setFormatter(logging.Formatter(STDERR_FORMAT))
            handler.setLevel(logging.WARNING)
            _add("stderr", handler, root)
        elif not stderr:
            _remove("stderr", root)
        if root.level == logging.NOTSET or root.level > level:
            root.setLevel(level)
        for name in QUIET_LIBRARIES:
            # their INFO is chatter (206 of 218 lines of a day's log were fontTools');
            # their warnings still reach the log
            logging.getLogger(name).setLevel(logging.WARNING)
        return Path(_installed["file"].baseFilename)


QUIET_LIBRARIES = ("fontTools", "matplotlib", "PIL", "numba", "h5py", "urllib3")
"""Libraries whose INFO and DEBUG lines are kept out of the clinic's log."""


def shutdown_logging() -> None:
    """Detach and close the handlers `setup_logging` installed."""
    root = logging.getLogger()
    with _lock:
        for key in list(_installed):
            _remove(key, root)


def _add(key: str, handler: logging.Handler, root: logging.Logger) -> None:
    _installed[key] = handler
    root.addHandler(handler)


def _remove(key: str, root: logging.Logger) -> None:
    handler = _installed.pop(key, None)
    if handler is not None:
        root.removeHandler(handler)
        handler.close()
