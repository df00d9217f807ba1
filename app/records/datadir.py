"""Where the console keeps its files, and how files are named.

Which folder, first match wins:

1. the environment variable REHAB_DATA_DIR, when set and not empty — for a
   study's own disk, a test, or a second console on a copy of the data;
2. the `data_dir` setting (app.records.settings), chosen in the window;
3. platformdirs' user data folder for "rehab-console" (on Linux
   ~/.local/share/rehab-console, on Windows %LOCALAPPDATA%\\rehab-console).

A relative path or one starting with ~ is expanded and made absolute at once,
so a later change of working folder cannot move the data.

Layout inside it::

    registry.sqlite3                  patients, sessions, trials (app.records.registry)
    trials/<code>/<code>_S003_T012_20240501T101502Z.h5
    reports/<code>/...                one per trial, named like its trial file
    exports/                          CSV, .mat and bundles for researchers
    logs/rehab-console-2024-05-01.log one per day (app.records.logs)
    models/<name>.json                learned robot models the CT-PID may run on
                                      (app.learning.library; made when first needed)

Every file name is built from the patient's pseudonymous code, the session and
trial numbers and a UTC time — never from a name, which lives only in the
registry. Folders are created when first needed; one that cannot be created or
written raises DataDirError saying which folder and what to do.
"""

from __future__ import annotations

import contextlib
import datetime
import os
import re
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import platformdirs

from app.errors import DataDirError
from app.records.settings import APP_NAME, Settings, load_settings

ENV_DATA_DIR = "REHAB_DATA_DIR"
REGISTRY_NAME = "registry.sqlite3"
TRIALS = "trials"
REPORTS = "reports"
PRIVATE_FOLDER = 0o700
PRIVATE_FILE = 0o600
"""The modes of the data folder's folders and files: its user's only (README, Where the
data goes)."""
EXPORTS = "exports"
LOGS = "logs"
MODELS = "models"
LAYOUT = (TRIALS, REPORTS, EXPORTS, LOGS)
TRIAL_SUFFIX = ".h5"

SOURCE_ENVIRONMENT = "environment"
SOURCE_SETTING = "setting"
SOURCE_DEFAULT = "default"

CODE_ALPHABET = "0123456789ABCDEFGHJKMNPQRSTVWXYZ"
"""Crockford's base32: digits and capitals without I, L, O and U, which read as 1, 0 or V."""
CODE_PATTERN = re.compile(r"P[0-9A-HJKMNP-TV-Z]{6}")
"""A patient code: 'P' and six base32 characters, about 10⁹ codes."""

_STAMP = "%Y%m%dT%H%M%SZ"
_MAX_NUMBER = 999_999


def default_data_dir() -> Path:
    return Path(platformdirs.user_data_dir(APP_NAME, appauthor=False))


def locate_data_dir(
    settings: Settings | None = None, environ: Mapping[str, str] | None = None
) -> DataDir:
    """The data folder by precedence: REHAB_DATA_DIR, then the setting, then the default.

    `settings` defaults to the saved settings (app.records.settings.load_settings); nothing
    is created here — see `DataDir.ensure`.
    """
    env = os.environ if environ is None else environ
    chosen = env.get(ENV_DATA_DIR, "").strip()
    if chosen:
        return DataDir(_absolute(chosen), SOURCE_ENVIRONMENT)
    if settings is None:
        settings = load_settings()
    if settings.data_dir:
        return DataDir(_absolute(settings.data_dir), SOURCE_SETTING)
    if settings.damaged:
        # the damaged settings may have named another folder: the default would start an
        # empty registry beside the real one
        raise DataDirError(
            f"the settings file was damaged and is kept as {settings.damaged}; the data "
            "folder it named cannot be read back. Set the data folder again "
            f"({ENV_DATA_DIR}=<folder>, or data_dir in the settings), or delete that file "
            f"to use the default folder {default_data_dir()}"
        )
    return DataDir(default_data_dir(), SOURCE_DEFAULT)


def check_code(code: str) -> str:
    """Return `code` when it is a registry patient code; anything else is refused
    without repeating it, since a caller passing a name must not get it logged."""
    if not isinstance(code, str) or not CODE_PATTERN.fullmatch(code):
        raise DataDirError(
            "file names are built from the registry's pseudonymous patient code "
            "('P' and 6 characters of 0-9 and A-Z without I, L, O, U), and the value "
            "given is not one: pass Patient.code, never a name"
        )
    return code


def trial_stem(code: str, session_number: int, trial_number: int,
               started_at: datetime.datetime) -> str:
    """`P7K2M9Q_S003_T012_20240501T101502Z`: code, session, trial and UTC start time."""
    check_code(code)
    for name, number in (("session", session_number), ("trial", trial_number)):
        if isinstance(number, bool) or not isinstance(number, int) or not (
            1 <= number <= _MAX_NUMBER
        ):
            raise DataDirError(f"{name} number {number!r}: give a whole number 1-{_MAX_NUMBER}")
    if started_at.tzinfo is None:
        raise DataDirError("the trial's start time has no time zone: give an aware datetime")
    stamp = started_at.astimezone(datetime.UTC).strftime(_STAMP)
    return f"{code}_S{session_number:03d}_T{trial_number:03d}_{stamp}"


@dataclass(frozen=True, slots=True)
class DataDir:
    """One data folder; `source` says which rule chose it (see the module's doc)."""

    root: Path
    source: str = SOURCE_DEFAULT

    @property
    def registry_path(self) -> Path:
        return self.root / REGISTRY_NAME

    @property
    def trials_dir(self) -> Path:
        return self.root / TRIALS

    @property
    def reports_dir(self) -> Path:
        return self.root / REPORTS

    @property
    def exports_dir(self) -> Path:
        return self.root / EXPORTS

    @property
    def logs_dir(self) -> Path:
        return self.root / LOGS

    @property
    def models_dir(self) -> Path:
        return self.root / MODELS

    def ensure(self, *parts: str) -> Path:
        """Create root/parts (and any parent) if missing, check it is writable, return it."""
        folder = self.root.joinpath(*parts)
        try:
            folder.mkdir(parents=True, exist_ok=True)
        except FileExistsError as exc:
            raise DataDirError(
                f"cannot create the folder {folder}: a file of that name is in the way "
                f"({exc.filename}). Move that file, or choose another data folder "
                f"(setting data_dir, or {ENV_DATA_DIR})"
            ) from exc
        except OSError as exc:
            raise self._not_writable(folder, exc) from exc
        if not folder.is_dir():
            raise DataDirError(
                f"{folder} is a file, not a folder. Move it, or choose another data folder "
                f"(setting data_dir, or {ENV_DATA_DIR})"
            )
        self._make_private(folder)
        self._probe(folder)
        return folder

    def _make_private(self, folder: Path) -> None:
        """The data folder and every folder in it open to their user only (0700), whatever
        the umask or an earlier console left: they hold patients' data."""
        here = folder
        while True:
            try:
                # only the group's and others' bits are taken away: a folder its user made
                # read-only stays read-only (and is refused as such below)
                bits = here.stat().st_mode & 0o777
                if bits & ~PRIVATE_FOLDER:
                    os.chmod(here, bits & PRIVATE_FOLDER)
            except OSError as exc:
                raise DataDirError(
                    f"cannot make {here} private to its user ({exc.strerror or exc}); the "
                    "data folder must be yours: choose another data folder (setting "
                    f"data_dir, or {ENV_DATA_DIR})"
                ) from exc
            if here == self.root or self.root not in here.parents:
                return
            here = here.parent

    def ensure_layout(self) -> Path:
        """Create the root and its standard sub-folders; return the root."""
        for part in LAYOUT:
            self.ensure(part)
        return self.root

    def patient_trials_dir(self, code: str) -> Path:
        return self.trials_dir / check_code(code)

    def trial_file(self, code: str, session_number: int, trial_number: int,
                   started_at: datetime.datetime) -> str:
        """The trial file's path relative to the root, with '/' on every system,
        as the registry stores it so the data folder can move or be copied."""
        stem = trial_stem(code, session_number, trial_number, started_at)
        return str(PurePosixPath(TRIALS, code, stem + TRIAL_SUFFIX))

    def report_path(self, code: str, session_number: int, trial_number: int,
                    started_at: datetime.datetime, suffix: str = ".pdf") -> Path:
        """Where a trial's report goes (not created)."""
        stem = trial_stem(code, session_number, trial_number, started_at)
        return self.reports_dir / code / (stem + suffix)

    def resolve(self, relative: str) -> Path:
        """The absolute path of a path stored relative to the root; refuses paths
        that would leave the data folder (absolute, or with '..')."""
        posix = PurePosixPath(relative)
        if posix.is_absolute() or ".." in posix.parts or not posix.parts:
            raise DataDirError(
                f"stored path {relative!r} is not inside the data folder: the registry "
                "keeps paths relative to it; repair the record or restore the registry"
            )
        return self.root.joinpath(*posix.parts)

    def relative(self, path: str | os.PathLike) -> str:
        """`path` relative to the root with '/' separators; refuses paths outside it."""
        try:
            inside = Path(path).absolute().relative_to(self.root.absolute())
        except ValueError:
            raise DataDirError(
                f"{path} is outside the data folder {self.root}: keep trial files inside it"
            ) from None
        return inside.as_posix()

    def _probe(self, folder: Path) -> None:
        # Permissions bits lie (ACLs, read-only mounts, root); only a write tells.
        try:
            handle, name = tempfile.mkstemp(dir=folder, prefix=".write-test-")
        except OSError as exc:
            raise self._not_writable(folder, exc) from exc
        os.close(handle)
        with contextlib.suppress(OSError):
            os.unlink(name)

    def _not_writable(self, folder: Path, exc: OSError) -> DataDirError:
        return DataDirError(
            f"cannot write in the data folder {folder}: {exc.strerror or exc}. Check its "
            f"permissions and that the disk is connected, or choose another data folder "
            f"(setting data_dir, or {ENV_DATA_DIR}; this one came from the {self.source})"
        )


def _absolute(text: str) -> Path:
    return Path(text).expanduser().absolute()


def private_files(path: Path) -> None:
    """`path` and SQLite's files beside it (-wal, -shm) readable by their user only (the
    group's and others' bits taken away), whatever the umask they were created
    with. SQLite gives the journal
    files the database's mode, so doing it once after opening holds."""
    for candidate in (path, path.with_name(path.name + "-wal"),
                      path.with_name(path.name + "-shm")):
        try:
            bits = candidate.stat().st_mode & 0o777
            if bits & ~PRIVATE_FILE:
                os.chmod(candidate, bits & PRIVATE_FILE)
        except FileNotFoundError:
            continue
        except OSError as exc:
            raise DataDirError(f"cannot make {candidate} private to its user "
                               f"({exc.strerror or exc}); the data folder must be yours") from exc
