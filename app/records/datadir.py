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
    offline/registry.sqlite3          a station's standby registry on a shared one: what
                                      it records while the server cannot be reached
                                      (app.records.station; synced-*.sqlite3 as sent)

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
import stat
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

import platformdirs

from app.errors import DataDirError
from app.records.settings import APP_NAME, Settings, load_settings
from device import safewrite
from device.safewrite import OutputRefused, folder_problem, make_private_folders, os_reason

ENV_DATA_DIR = "REHAB_DATA_DIR"
REGISTRY_NAME = "registry.sqlite3"
TRIALS = "trials"
# trials/simulated: where `rehab run` without --code wrote its unregistered trials until
# 2026-12-06 (now it keeps none); a data folder may still hold them
SIMULATED = "simulated"
REPORTS = "reports"
PRIVATE_FOLDER = safewrite.PRIVATE_FOLDER
PRIVATE_FILE = safewrite.PRIVATE_FILE
"""The modes of the data folder's folders and files: its user's only (README, Where the
data goes)."""
EXPORTS = "exports"
LOGS = "logs"
MODELS = "models"
OFFLINE = "offline"
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
            f"the settings file {settings.damaged} is damaged or cannot be read (kept as it "
            "is); the data folder it named cannot be read back. Set the data folder again "
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
        """root/parts, created where missing (new folders 0700, whatever the umask), checked
        writable, returned. The root is created only where nothing is; an existing root is
        never changed, only checked: a folder of this user's alone (owned, writable by no
        one else, on a path no one else can swap), else DataDirError saying why and what to
        do. The console's own folders inside it are kept 0700.

        Checked whole once a process: while the folders checked (the root, the folders
        above it and `parts`) are the same ones with the same owner and mode (`_standing`),
        a later call returns at once (a trial's registration calls it each time: its
        checks, 21 system calls, were a fifth of `begin_trial`'s CPU under cProfile,
        docs/performance.md). A folder removed, replaced, chmodded or given away meanwhile
        changes that, and the whole check runs again (a folder made read-only by its mode
        is refused here as before). What is not seen until the file is written: a disk
        remounted read-only, full or unplugged with the modes unchanged; the trial
        file's own creation then fails and says so (device.recording.trialfile.making),
        and the run that registered it takes the trial back (app.trials.registered)."""
        key = (self.root, parts)
        checked = _CHECKED.get(key)
        if checked is not None:
            folders, standing = checked
            if standing is not None and _standing(folders) == standing:
                return folders[-1]
            _CHECKED.pop(key, None)
        self._check_root()
        folder = self.root
        for part in parts:
            folder = folder / part
            self._own_folder(folder)
        self._probe(folder)
        # the folders whose owner and mode the checks read: those above the root as
        # `folder_problem` walks them (the real path's), the root, then each part
        above = list(reversed(Path(os.path.realpath(self.root)).parents))
        folders = (*above, self.root, *(self.root.joinpath(*parts[:i + 1])
                                        for i in range(len(parts))))
        standing = _standing(folders)
        if standing is not None:  # else gone again already: checked whole next time too
            _CHECKED[key] = (folders, standing)
        return folder

    def _check_root(self) -> None:
        try:
            info = os.stat(self.root)
        except FileNotFoundError:
            try:
                make_private_folders(self.root)
                info = os.stat(self.root)
            except OutputRefused as exc:
                raise DataDirError(f"{exc} (the data folder; {self._choose()})") from None
            except OSError as exc:
                raise DataDirError(f"cannot use the data folder {self.root}: "
                                   f"{os_reason(exc)}. {self._choose(first=True)}") from None
        except (OSError, RecursionError, ValueError) as exc:
            raise DataDirError(f"cannot use the data folder {self.root}: {os_reason(exc)}. "
                               f"{self._choose(first=True)}") from None
        if not stat.S_ISDIR(info.st_mode):
            raise DataDirError(f"the data folder {self.root} is a file, not a folder. Move it, "
                               f"or {self._choose()}")
        if not os.path.lexists(self.registry_path):
            others = foreign_entries(self.root)
            if others:
                # `--data-dir ~` or `/`: no trials/, logs/ or registry made among other files
                raise DataDirError(
                    f"{self.root} is not a data folder: it holds {others} and no registry. A "
                    "data folder, and a new registry, start only in a new or empty folder: "
                    f"{self._choose()}")
        problem = folder_problem(self.root)
        if problem:
            raise DataDirError(
                f"the data folder {self.root} {problem}: patients' data must be private to "
                f"you. {self._choose(first=True)}, or make it yours alone "
                f"(chmod 700 {self.root}); the console never changes a folder it did not make")

    def _choose(self, *, first: bool = False) -> str:
        """What to do instead, as a clause; `first`: opening a sentence (str.capitalize would
        lowercase the variable's name, which must be typed as it is)."""
        return (f"{'C' if first else 'c'}hoose another data folder (--data-dir, the setting "
                f"data_dir, or {ENV_DATA_DIR}; this one came from the {self.source})")

    def _own_folder(self, folder: Path) -> None:
        """One of the console's folders inside the data folder: made 0700 where missing;
        one an earlier console left open (it made it) closed to its user again; a link to a
        folder elsewhere (a second disk) followed only if that folder is private, and never
        changed."""
        try:
            info = os.lstat(folder)
        except FileNotFoundError:
            try:
                os.mkdir(folder, PRIVATE_FOLDER)
                os.chmod(folder, PRIVATE_FOLDER)  # the umask may have taken the owner's bits
            except FileExistsError:
                self._own_folder(folder)  # made meanwhile by another console
            except OSError as exc:
                raise self._not_writable(folder, exc) from exc
            return
        except OSError as exc:
            raise DataDirError(f"cannot use {folder} in the data folder: {os_reason(exc)}. "
                               f"{self._choose(first=True)}") from None
        if stat.S_ISLNK(info.st_mode):
            problem = folder_problem(folder)
            if problem:
                raise DataDirError(f"{folder} in the data folder is a link to a folder that "
                                   f"{problem}; link it to a folder of yours alone, or "
                                   f"{self._choose()}")
            return
        if not stat.S_ISDIR(info.st_mode):
            raise DataDirError(
                f"cannot create the folder {folder}: a file of that name is in the way. Move "
                f"that file, or {self._choose()}")
        bits = stat.S_IMODE(info.st_mode)
        if bits & ~PRIVATE_FOLDER:
            # only the group's and others' bits are taken away: a folder its user made
            # read-only stays read-only (and is refused as such by the probe)
            try:
                os.chmod(folder, bits & PRIVATE_FOLDER)
            except OSError as exc:
                raise DataDirError(
                    f"cannot make {folder} private to its user ({os_reason(exc)}); the data "
                    f"folder must be yours: {self._choose()}") from exc

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


_CHECKED: dict[tuple[Path, tuple[str, ...]], tuple[tuple[Path, ...], tuple | None]] = {}
"""`DataDir.ensure`'s folders checked whole in this process: (root, parts) -> the folders
the checks read, and what the system said of them then (`_standing`)."""


def _standing(folders: tuple[Path, ...]) -> tuple | None:
    """Which folders these are and how they stand: each one's device, inode, type and mode,
    owner and group, as `os.lstat` says, and as `os.stat` says where one is a link; None
    when one cannot be read (gone: the whole check runs again and says why)."""
    said = []
    try:
        for folder in folders:
            info = os.lstat(folder)
            said.append((info.st_dev, info.st_ino, info.st_mode, info.st_uid, info.st_gid))
            if stat.S_ISLNK(info.st_mode):
                info = os.stat(folder)
                said.append((info.st_dev, info.st_ino, info.st_mode, info.st_uid,
                             info.st_gid))
    except (OSError, ValueError):
        return None
    return tuple(said)


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


_LAYOUT_NAMES = frozenset((*LAYOUT, MODELS, OFFLINE))


def foreign_entries(root: Path) -> str:
    """What `root` holds besides a data folder's own folders and files (its registry and
    copies, the layout's folders) and hidden files: '' or a few names and their count."""
    try:
        names = sorted(entry.name for entry in os.scandir(root)
                       if not entry.name.startswith((".", REGISTRY_NAME))
                       and entry.name not in _LAYOUT_NAMES)
    except OSError:
        return ""
    if not names:
        return ""
    listed = ", ".join(names[:3]) + (", …" if len(names) > 3 else "")
    return f"{len(names)} entr{'y' if len(names) == 1 else 'ies'}: {listed}"


def registered_trial_count(trials_dir: Path) -> int:
    """How many trial files below `trials_dir` a registry would own: every .h5 but those of
    its simulated/ folder, which `rehab run` wrote without --code and never registered. A
    registry missing beside the others orphans them (check_registry_file); the simulated
    ones alone orphan nothing, so they must not stop a first `rehab patients add`."""
    if not trials_dir.is_dir():
        return 0
    simulated = trials_dir / SIMULATED
    return sum(1 for path in trials_dir.rglob("*.h5") if not path.is_relative_to(simulated))
