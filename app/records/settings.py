"""The console's small settings file: one JSON object in the user's config folder.

Where: `$REHAB_CONFIG_DIR/settings.json` when that variable is set and not empty,
else platformdirs' user config folder for "rehab-console" (on Linux
~/.config/rehab-console, on Windows %LOCALAPPDATA%\\rehab-console).

Writes are atomic (device.safewrite: a temporary file in the same folder, 0600,
fsynced, then renamed over the old one), so a crash or a second console never leaves
half a file. A file that cannot be trusted whole (not a JSON object, NaN, nested past
reason, larger than 1 MiB, not a plain file, a version or any value of the wrong
type) is renamed `settings.json.corrupt-<UTC time>`, with a logged warning, and the
defaults are used but for its data folder, kept when the file still names one; when
it names none that can be read back, the data folder is unknown and the console says
so rather than open the default folder's registry (app.records.datadir). The
therapist loses preferences, never their patients. Keys this version does not know
are kept on save, so an older console does not erase a newer one's settings. A
settings.json that is a symbolic link is read and saved through to its target, the link
kept (`linked_file`).
"""

from __future__ import annotations

import contextlib
import dataclasses
import datetime
import json
import logging
import os
import re
import stat
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import platformdirs

from app.errors import SettingsError
from core.errors import CoreError
from core.trial import TrialParameters
from device.safeinput import InputRefused, read_bytes
from device.safewrite import OutputRefused, make_private_folders, write_text

log = logging.getLogger(__name__)

APP_NAME = "rehab-console"
ENV_CONFIG_DIR = "REHAB_CONFIG_DIR"
SETTINGS_NAME = "settings.json"
SETTINGS_VERSION = 1
_VERSION_KEY = "settings_version"


def _optional_text(value: object) -> bool:
    return value is None or (isinstance(value, str) and value.strip() != "")


def _flag(value: object) -> bool:
    return isinstance(value, bool)


def _optional_object(value: object) -> bool:
    return value is None or isinstance(value, dict)


def _optional_string(value: object) -> bool:
    return value is None or isinstance(value, str)


def _robot_choice(value: object) -> bool:
    return value in ("simulator", "hardware")


# What each stored value must be; the message completes "give ...".
_CHECKS: dict[str, tuple[Callable[[object], bool], str]] = {
    "data_dir": (_optional_text, "a folder path, or null for the default"),
    "flip_x": (_flag, "true or false"),
    "flip_y": (_flag, "true or false"),
    "last_trial_parameters": (_optional_object, "an object of trial parameters, or null"),
    "window_geometry": (_optional_string, "a string, or null"),
    "robot": (_robot_choice, '"simulator" or "hardware"'),
    "virtual_patient": (_optional_text, "a virtual patient's kind (healthy, weak, …), or null"),
    "hardware_settings": (_optional_text, "the hardware settings file's path, or null"),
    "patient_screen": (_optional_object, "an object of the patient's screen's options, or null"),
    "trial_store": (_optional_text, "the shared trial store's folder for this station (an "
                    "absolute path), or null for none"),
}


@dataclass(frozen=True, slots=True)
class Settings:
    """Every setting with its default.

    data_dir: the data folder chosen by the user (REHAB_DATA_DIR still wins).
    flip_x, flip_y: mirror the live display's axes (display only; data stay in
        the robot frame).
    last_trial_parameters: `TrialParameters.to_dict()` of the last trial run,
        read back through `trial_parameters()`.
    window_geometry: the window's saved geometry, opaque to everything but ui.
    robot, virtual_patient, hardware_settings: the robot the Parameters tab last chose
        ("simulator" with its virtual patient's kind, or "hardware" with its settings
        file), so a restart does not quietly go back to a healthy virtual patient.
    patient_screen: the patient's screen's options (ui.views.patient_screen.PatientOptions
        .to_dict(): mirrored, turned, what it shows), checked by the window when it reads
        them.
    trial_store: the department's shared trial store for this station (a network folder,
        e.g. /mnt/rehab-trials/robot-2): each finished trial's file is copied there and
        proven whole (app.records.trialstore); None keeps the files in the data folder only.
    extra: keys written by another version of the console, kept untouched.
    """

    data_dir: str | None = None
    flip_x: bool = False
    flip_y: bool = False
    last_trial_parameters: dict | None = None
    window_geometry: str | None = None
    robot: str = "simulator"
    virtual_patient: str | None = None
    hardware_settings: str | None = None
    patient_screen: dict | None = None
    trial_store: str | None = None
    extra: dict = field(default_factory=dict, repr=False)
    damaged: str | None = field(default=None, compare=False)
    """The damaged settings file kept aside whose data folder could not be read back, or
    None: then the data folder is not known (locate_data_dir refuses to guess)."""

    def __post_init__(self) -> None:
        for name, (ok, allowed) in _CHECKS.items():
            value = getattr(self, name)
            if not ok(value):
                raise SettingsError(f"setting {name} = {value!r} is not allowed: give {allowed}")
        if not isinstance(self.extra, dict):
            raise SettingsError("setting extra must be a dict of the unknown keys")

    def replace(self, **changes) -> Settings:
        return dataclasses.replace(self, **changes)

    def trial_parameters(self) -> TrialParameters | None:
        """The last trial's parameters, or None when none were saved or they no
        longer validate (an older console's fields, a range since narrowed)."""
        if self.last_trial_parameters is None:
            return None
        try:
            return TrialParameters.from_dict(self.last_trial_parameters)
        except (CoreError, TypeError, ValueError) as exc:
            log.warning("saved trial parameters ignored, defaults used instead: %s", exc)
            return None

    def with_trial_parameters(self, parameters: TrialParameters) -> Settings:
        return self.replace(last_trial_parameters=parameters.to_dict())

    def to_json(self) -> dict:
        values = {name: getattr(self, name) for name in _CHECKS}
        return {**self.extra, _VERSION_KEY: SETTINGS_VERSION, **values}


def config_dir(environ: Mapping[str, str] | None = None) -> Path:
    """The settings folder: $REHAB_CONFIG_DIR if set and not empty, else platformdirs'."""
    env = os.environ if environ is None else environ
    chosen = env.get(ENV_CONFIG_DIR, "").strip()
    if chosen:
        return Path(chosen).expanduser().absolute()
    return Path(platformdirs.user_config_dir(APP_NAME, appauthor=False))


def settings_path(environ: Mapping[str, str] | None = None) -> Path:
    return config_dir(environ) / SETTINGS_NAME


def load_settings(path: str | os.PathLike | None = None) -> Settings:
    """Read the settings; a missing file gives the defaults. A file that cannot be trusted
    whole (not a plain file, too large, not UTF-8 JSON, NaN, nested past reason, a version
    or any setting of the wrong type) is set aside and only its data folder kept, when it
    names one that can be read back; one that cannot be read leaves the data folder
    unknown: never is a data folder silently replaced by the default (locate_data_dir
    refuses to guess)."""
    path = linked_file(Path(path) if path is not None else settings_path())
    try:
        info = os.stat(path)
    except FileNotFoundError:
        kept = sorted(path.parent.glob(f"{path.name}.corrupt-*"))
        if kept:
            # an earlier start set a damaged file aside: until someone looks at it, the
            # data folder it may have named is unknown, not the default
            return Settings(damaged=str(kept[-1]))
        log.debug("no settings file at %s: defaults used", path)
        return Settings()
    except (OSError, ValueError) as exc:
        log.warning("settings file %s cannot be read (%s): its data folder is unknown",
                    path, exc)
        return Settings(damaged=str(path))
    if not stat.S_ISREG(info.st_mode):
        return _set_aside(path, "it is not a plain file")
    if info.st_size > MAX_SETTINGS_BYTES:
        return _set_aside(path, f"it is {info.st_size} bytes, more than settings can be")
    try:
        raw = path.read_bytes()
    except OSError as exc:
        log.warning("settings file %s cannot be read (%s): its data folder is unknown",
                    path, exc)
        return Settings(damaged=str(path))
    try:
        values = json.loads(raw.decode("utf-8"), parse_constant=_refuse_constant)
    except UnicodeDecodeError:
        return _set_aside(path, "it is not UTF-8 text")
    except (ValueError, RecursionError) as exc:
        return _set_aside(path, f"it is not valid JSON ({_short(exc)})")
    if not isinstance(values, dict):
        return _set_aside(path, "it is not a JSON object")
    version = values.get(_VERSION_KEY, SETTINGS_VERSION)
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        return _set_aside(path, f"its {_VERSION_KEY} {_short(version)} is not a version "
                                "number")
    for name, (ok, allowed) in _CHECKS.items():
        if name in values and not ok(values[name]):
            return _set_aside(path, f"setting {name} = {_short(values[name])} is not allowed "
                                    f"(give {allowed})")
    extra = {k: v for k, v in values.items() if k not in _CHECKS and k != _VERSION_KEY}
    return Settings(**{name: values[name] for name in _CHECKS if name in values}, extra=extra)


MAX_SETTINGS_BYTES = 1 << 20
"""Settings are a few hundred bytes; a megabyte is not a settings file."""


def _refuse_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


def _short(value: object) -> str:
    """A value or an error for a log line: one line, at most 80 characters."""
    try:
        text = str(value) if isinstance(value, BaseException) else repr(value)
    except RecursionError:
        text = f"a {type(value).__name__} nested too deeply"
    text = " ".join(text.split())
    return text if len(text) <= 80 else text[:77] + "..."


def save_settings(settings: Settings, path: str | os.PathLike | None = None) -> Path:
    """Write the settings atomically, 0600; SettingsError when the folder is not writable
    (the previous settings are then unchanged)."""
    path = Path(path) if path is not None else settings_path()
    text = json.dumps(settings.to_json(), indent=2, sort_keys=True, allow_nan=False) + "\n"
    try:
        make_private_folders(path.parent)
        write_text(linked_file(path), text, overwrite=True)
    except OutputRefused as exc:
        raise SettingsError(
            f"cannot write the settings: {exc}. The previous settings are unchanged; check "
            f"the folder, or set {ENV_CONFIG_DIR} to a folder you can write to") from None
    return path


def linked_file(path: Path) -> Path:
    """The file the settings path names: a symbolic link's target, links followed to the
    end, else the path itself.

    A user who keeps settings.json in a folder of their own (a dotfiles repository) and
    links it here expects the console to read and save that file, as git writes a linked
    ~/.gitconfig through to its target and vim or emacs save through a link: saving over
    the name replaced the link by a plain file, and the user's file silently stopped
    being the one in use. The settings hold no secret (the registry's URL, which may, is
    in its own file, which refuses a link: app.records.registry.url), so following the
    link reveals nothing; a damaged target is set aside beside itself, the link kept. A
    link to nothing is saved through, creating its target in a folder that exists; a
    loop is reported where the file is read or written, in one line."""
    if not os.path.islink(path):
        return path
    target = Path(os.path.realpath(path))
    log.debug("settings file %s is a link to %s: that file is read and saved", path, target)
    return target


def update_settings(path: str | os.PathLike | None = None, **changes) -> Settings:
    """Load, change the given settings, save, and return the result.

    Two consoles saving at the same moment: the last write wins whole, never a mix.
    """
    settings = load_settings(path).replace(**changes)
    save_settings(settings, path)
    return settings


def _set_aside(path: Path, problem: str) -> Settings:
    stamp = datetime.datetime.now(datetime.UTC).strftime("%Y%m%dT%H%M%SZ")
    target = path.with_name(f"{path.name}.corrupt-{stamp}")
    counter = 1
    while target.exists():
        counter += 1
        target = path.with_name(f"{path.name}.corrupt-{stamp}-{counter}")
    recovered = _data_dir_in(path)
    try:
        os.replace(path, target)
    except OSError as exc:
        log.warning(
            "settings file %s is unusable (%s) and could not be set aside (%s): defaults used",
            path, problem, exc,
        )
        return Settings(data_dir=recovered, damaged=None if recovered else str(path))
    log.warning(
        "settings file %s is unusable (%s): kept as %s for inspection, defaults used%s",
        path, problem, target.name,
        f" but its data folder {recovered}" if recovered else "",
    )
    if recovered:
        # the data folder is what matters: the rest (window, last parameters) can wait
        settings = Settings(data_dir=recovered)
        with contextlib.suppress(SettingsError):
            save_settings(settings, path)
        return settings
    return Settings(damaged=str(target))


_DATA_DIR_ENTRY = re.compile(r'"data_dir"\s*:\s*("(?:[^"\\]|\\.)*")')


def _data_dir_in(path: Path) -> str | None:
    """The data folder a damaged settings file still names (a truncated file often keeps
    its first keys whole), or None."""
    try:
        text = read_bytes(path, max_bytes=MAX_SETTINGS_BYTES).decode("utf-8",
                                                                     errors="surrogateescape")
    except InputRefused:  # not a plain file, too large: nothing to read back
        return None
    found = _DATA_DIR_ENTRY.search(text)
    if found is None or any("\udc80" <= c <= "\udcff" for c in found.group(1)):
        # a byte of the folder's name itself damaged (not UTF-8; the console writes
        # ASCII): read back with a replacement character it was another folder
        return None
    try:
        value = json.loads(found.group(1))
    except ValueError:
        return None
    return value if isinstance(value, str) and value.strip() else None
