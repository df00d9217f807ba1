"""This installation's secret key and the keyed signature of the files that decide what
drives the robot: the learned models and the approved EMG models (docs/data-format.md,
"Signatures").

Why a key. A model file carried a SHA-256 of its content, which anyone can recompute: an
EMG model's validated cone edited from 20° to 10° and its hash recomputed made a 10° trial
pass that the real approval refuses, and a learned model alike. A signature made with a
secret only this installation holds (HMAC-SHA256, RFC 2104) cannot be recomputed by
whoever edits the file, so an approval cannot be re-signed by editing. A file from
elsewhere (another console, the thesis's models) is brought in by `rehab models import`,
which checks it as the console checks its own (its hash, its weights, the approval rule)
and signs it here: the one place a file from outside becomes trusted, by a person's act.

The key: 32 random bytes in hex, `installation.key` in the user's config folder
(app.records.settings.config_dir, `REHAB_CONFIG_DIR` when set), created 0600 in a folder
created 0700, and refused unless its owner is this user and no one else may read it or
replace it. Never in the data folder, which travels with backups and copies.
"""

from __future__ import annotations

import hashlib
import hmac
import json
import os
import secrets
import stat
from pathlib import Path

from app.errors import AppError
from app.records.settings import ENV_CONFIG_DIR, config_dir
from device.safewrite import OutputRefused, make_private_folders, write_text

KEY_NAME = "installation.key"
KEY_BYTES = 32
ALGORITHM = "hmac-sha256"
SIGNATURE = "signature"
"""The key of a signed JSON document's signature: {"algorithm", "key_id", "value"}."""

_cache: dict[Path, bytes] = {}


class SigningError(AppError):
    """This installation's key cannot be made or trusted; one line with what to do."""


def key_path() -> Path:
    return config_dir() / KEY_NAME


def installation_key() -> bytes:
    """The key, created the first time (one per user and config folder); SigningError when
    it or its folder could be read or replaced by someone else."""
    path = key_path()
    if path in _cache:
        return _cache[path]
    folder = path.parent
    if not folder.exists():
        try:
            make_private_folders(folder)  # 0700, whatever the umask
        except OutputRefused as exc:
            raise SigningError(f"cannot create the config folder for this installation's "
                               f"key: {exc}; set {ENV_CONFIG_DIR} to a folder you own"
                               ) from None
    _check_folder(folder)
    try:
        key = _read(path)
    except FileNotFoundError:
        key = _create(path)
    _cache[path] = key
    return key


def _owner_problem(st: os.stat_result) -> str:
    if hasattr(os, "getuid") and st.st_uid != os.getuid():
        return f"belongs to user {st.st_uid}, not to you"
    return ""


def _check_folder(folder: Path) -> None:
    try:
        st = folder.stat()
    except OSError as exc:
        raise SigningError(f"the config folder {folder} cannot be examined "
                           f"({exc.strerror or exc})") from None
    if not stat.S_ISDIR(st.st_mode):
        raise SigningError(f"{folder} is not a folder; set {ENV_CONFIG_DIR} to a folder you "
                           "own")
    problem = _owner_problem(st)
    if not problem and os.name == "posix" and st.st_mode & 0o022:
        problem = f"can be written by others (mode {stat.S_IMODE(st.st_mode):o})"
    if problem:
        raise SigningError(f"the config folder {folder}, which holds this installation's "
                           f"signing key, {problem}: anyone who can write there could replace "
                           f"the key. Run `chmod 700 {folder}` or set {ENV_CONFIG_DIR} to a "
                           "private folder")


def _read(path: Path) -> bytes:
    flags = os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise SigningError(f"this installation's key {path} cannot be read "
                           f"({exc.strerror or exc}); it must be a file of yours, not a "
                           "link") from None
    with os.fdopen(fd, "rb") as stream:
        st = os.fstat(stream.fileno())
        problem = "" if stat.S_ISREG(st.st_mode) else "is not a plain file"
        problem = problem or _owner_problem(st)
        if not problem and os.name == "posix" and st.st_mode & 0o077:
            problem = f"can be read by others (mode {stat.S_IMODE(st.st_mode):o})"
        if problem:
            raise SigningError(f"this installation's key {path} {problem}. Run `chmod 600 "
                               f"{path}`; if someone else may have read it, delete it and "
                               "import your models again (rehab models import)")
        text = stream.read(4 * KEY_BYTES).decode("ascii", "replace").strip()
    try:
        key = bytes.fromhex(text)
    except ValueError:
        key = b""
    if len(key) != KEY_BYTES:
        raise SigningError(f"this installation's key {path} is damaged (not {KEY_BYTES} bytes "
                           "in hex). Delete it and import your models again (rehab models "
                           "import): files signed with it are no longer trusted")
    return key


def _create(path: Path) -> bytes:
    key = secrets.token_bytes(KEY_BYTES)
    try:
        # whole or not at all, 0600 from the start, never over a key another console made
        # meanwhile (device.safewrite: a temporary linked into place)
        write_text(path, key.hex() + "\n")
    except OutputRefused as exc:
        if os.path.lexists(path):
            return _read(path)  # made meanwhile: that one is the installation's key
        raise SigningError(f"cannot create this installation's key: {exc}; set "
                           f"{ENV_CONFIG_DIR} to a folder you can write") from None
    return key


def canonical(document: dict) -> bytes:
    """The document without its signature, keys sorted, no spaces: what is signed (the same
    serialisation as a model file's content_sha256)."""
    body = {k: v for k, v in document.items() if k != SIGNATURE}
    return json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False).encode()


def key_id(key: bytes) -> str:
    """Names the key without revealing it: which installation signed a file."""
    return hashlib.sha256(b"rehab-console key id\0" + key).hexdigest()[:16]


def sign(document: dict) -> dict:
    """The document with this installation's signature (replacing any other)."""
    key = installation_key()
    value = hmac.new(key, canonical(document), hashlib.sha256).hexdigest()
    return {**{k: v for k, v in document.items() if k != SIGNATURE},
            SIGNATURE: {"algorithm": ALGORITHM, "key_id": key_id(key), "value": value}}


def unsigned(document: dict) -> dict:
    return {k: v for k, v in document.items() if k != SIGNATURE}


def signature_problem(document: dict) -> str:
    """Why the document's signature is not this installation's ("" when it is)."""
    signature = document.get(SIGNATURE)
    if not isinstance(signature, dict):
        return ("it carries no signature of this installation (written elsewhere, or before "
                "models were signed)")
    key = installation_key()
    if signature.get("algorithm") != ALGORITHM or signature.get("key_id") != key_id(key):
        return "it was signed by another installation"
    expected = hmac.new(key, canonical(document), hashlib.sha256).hexdigest()
    value = signature.get("value")
    if not isinstance(value, str) or not hmac.compare_digest(value, expected):
        return "it was changed after it was signed (its signature does not match)"
    return ""
