"""The registry URL, read from a file private to its user (app.records.registry.url): the
default when there is none, and one line for every file or URL refused."""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from pathlib import Path

import pytest

from app.errors import RegistryURLError
from app.records.datadir import DataDir
from app.records.registry.url import URL_NAME, registry_url, url_file

SECRET = "s3cret-Pw"
NOBODY = 65534


@pytest.fixture
def config(tmp_path, monkeypatch) -> Path:
    folder = tmp_path / "config"
    folder.mkdir(mode=0o700)
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(folder))
    return folder


@pytest.fixture
def data_dir(tmp_path) -> DataDir:
    return DataDir(tmp_path / "data", "command line")


def write(config: Path, text: str | bytes, mode: int = 0o600) -> Path:
    path = config / URL_NAME
    data = text.encode() if isinstance(text, str) else text
    path.write_bytes(data)
    path.chmod(mode)
    return path


def refusal(data_dir: DataDir) -> str:
    with pytest.raises(RegistryURLError) as refused:
        registry_url(data_dir)
    message = str(refused.value)
    assert "\n" not in message
    assert SECRET not in message
    return message


def test_without_a_url_file_the_data_folders_sqlite_registry_is_used(config, data_dir):
    assert url_file() == config / URL_NAME
    found = registry_url(data_dir)
    assert found.engine == "sqlite"
    assert found.path == data_dir.registry_path
    assert found.source == ("the data folder given by the command line; no registry URL file "
                            f"at {config / URL_NAME}")


def test_a_stations_data_folder_without_its_url_file_is_refused_saying_so(config, data_dir):
    """A station's folder (trial files, its standby in offline/, no registry.sqlite3) opened
    without its registry.url (another user's HOME, sudo, a wrong REHAB_CONFIG_DIR): it said
    'the registry … is missing, but … holds 4 trial file(s): restore the registry from a
    backup', a registry the station never had."""
    (data_dir.root / "offline").mkdir(parents=True)
    assert refusal(data_dir) == (
        f"the data folder {data_dir.root} is a station's on a shared registry (it has an "
        f"offline folder), but there is no registry URL file at {config / URL_NAME}: run "
        "this as the station's user, set REHAB_CONFIG_DIR to the folder that holds its "
        "registry.url, or put that file there (mode 600; README, Several stations)")
    data_dir.registry_path.write_bytes(b"")  # a folder with a registry of its own: as always
    assert registry_url(data_dir).engine == "sqlite"


def test_a_postgresql_url_is_read_and_shown_without_its_password(config, data_dir):
    write(config, f"# the department's registry\n\npostgresql://station3:{SECRET}@"
                  "registry.clinic.local:5433/rehab\n")
    found = registry_url(data_dir)
    assert found.engine == "postgresql"
    assert found.url.password == SECRET
    assert found.url.drivername == "postgresql+psycopg"
    # shown as the file says it: no password, and not the driver the console adds
    assert found.shown == "postgresql://station3:***@registry.clinic.local:5433/rehab"
    assert found.server == "registry.clinic.local:5433"
    assert str(config / URL_NAME) in found.source


def test_libpqs_postgres_scheme_is_postgresql(config, data_dir):
    """psql and libpq take postgres:// as well as postgresql://; it was an internal error
    (SQLAlchemy has no dialect of that name)."""
    write(config, f"postgres://station3:{SECRET}@registry.clinic.local/rehab\n")
    found = registry_url(data_dir)
    assert found.engine == "postgresql"
    assert found.url.drivername == "postgresql+psycopg"
    assert found.shown == "postgresql://station3:***@registry.clinic.local/rehab"


def test_a_sqlite_url_names_its_file(config, data_dir, tmp_path):
    write(config, f"sqlite:///{tmp_path}/elsewhere/registry.sqlite3")
    found = registry_url(data_dir)
    assert (found.engine, found.path) == ("sqlite", tmp_path / "elsewhere/registry.sqlite3")


def test_the_settings_file_is_never_read_for_a_url(config, data_dir):
    (config / "settings.json").write_text(json.dumps(
        {"registry_url": f"postgresql://u:{SECRET}@h/db"}))
    assert registry_url(data_dir).engine == "sqlite"


@pytest.mark.parametrize(("mode", "shown"), [(0o644, "644"), (0o640, "640"), (0o604, "604"),
                                            (0o620, "620"), (0o666, "666")])
def test_a_file_others_may_read_or_write_is_refused(config, data_dir, mode, shown):
    path = write(config, f"postgresql://u:{SECRET}@h/db", mode)
    assert refusal(data_dir) == (
        f"the registry URL file {path} can be read or written by others (mode {shown}): run "
        f"`chmod 600 {path}`; if others may have read a password in it, change that "
        "password on the server")


def test_a_file_of_another_user_is_refused(config, data_dir, monkeypatch):
    path = write(config, f"postgresql://u:{SECRET}@h/db")
    if os.geteuid() == 0:
        os.chown(path, NOBODY, NOBODY)
    else:  # an unprivileged run cannot give a file away: this user becomes someone else
        monkeypatch.setattr(os, "geteuid", lambda: NOBODY)
    message = refusal(data_dir)
    assert message.startswith(f"the registry URL file {path} belongs to user ")
    assert message.endswith("the console reads a URL (and its password) only from a file of "
                            "the user who runs it; copy it into a file of yours and run "
                            "`chmod 600` on it")


def test_a_symbolic_link_is_refused_even_to_a_private_file(config, data_dir, tmp_path):
    target = write(tmp_path, f"postgresql://u:{SECRET}@h/db")
    (config / URL_NAME).symlink_to(target)
    path = config / URL_NAME
    assert refusal(data_dir) == (
        f"the registry URL file {path} is a symbolic link: whoever owns it could turn it to "
        f"another file; put the URL in a plain file there and run `chmod 600 {path}`")


def test_a_folder_in_its_place_is_refused(config, data_dir):
    (config / URL_NAME).mkdir(mode=0o700)
    assert refusal(data_dir) == (f"the registry URL file {config / URL_NAME} is not a plain "
                                 "file: put the registry URL on one line in a plain file")


def test_a_file_in_a_folder_others_can_write_is_refused(config, data_dir):
    write(config, f"postgresql://u:{SECRET}@h/db")
    config.chmod(0o777)
    message = refusal(data_dir)
    assert message.startswith(f"the registry URL file {config / URL_NAME} lies in {config}, "
                              "which can be written by others (mode 777): whoever can write "
                              f"there could replace the file; run `chmod 700 {config}`")


def test_a_file_its_user_cannot_read_is_refused(config, data_dir):
    """Mode 200: the user's own, private, and unreadable. Root reads any file, so a root run
    becomes an unprivileged user (nobody) for the moment of reading one of its own, in a
    folder of its own."""
    if os.geteuid() != 0:
        path = write(config, f"postgresql://u:{SECRET}@h/db", 0o200)
        message = refusal(data_dir)
    else:
        folder = Path(tempfile.mkdtemp(prefix="rehab-url-"))
        try:
            path = write(folder, f"postgresql://u:{SECRET}@h/db", 0o200)
            for item in (folder, path):
                os.chown(item, NOBODY, NOBODY)
            os.setegid(NOBODY)
            os.seteuid(NOBODY)
            try:
                with pytest.raises(RegistryURLError) as refused:
                    registry_url(data_dir, path)
            finally:
                os.seteuid(0)
                os.setegid(0)
            message = str(refused.value)
        finally:
            with contextlib.suppress(OSError):
                shutil.rmtree(folder)
    assert message == (f"the registry URL file {path} cannot be read (Permission denied): it "
                       f"must be a file of yours; run `chmod 600 {path}` as its owner, or "
                       "remove it to use the data folder's registry")


EXAMPLES = ("sqlite:////absolute/path/registry.sqlite3 or "
            "postgresql://user:password@host:port/database")


@pytest.mark.parametrize(("text", "problem"), [
    ("not a url", "is not a URL that can be read: write it as " + EXAMPLES + " (a port is a "
     "number; a password with @, : or / is written %40, %3A, %2F)"),
    (f"postgresql://u:{SECRET}@h:abc/db", "is not a URL that can be read: write it as "
     + EXAMPLES + " (a port is a number; a password with @, : or / is written %40, %3A, "
     "%2F)"),
    (f"mysql://u:{SECRET}@h/db", "has the scheme 'mysql', which this console does not "
     "know: give " + EXAMPLES),
    (f"http://u:{SECRET}@h/db", "has the scheme 'http', which this console does not "
     "know: give " + EXAMPLES),
    (f"postgres+psycopg2://u:{SECRET}@h/db", "asks for the driver 'psycopg2': this "
     "console talks to postgresql with psycopg; write postgresql://…"),
    (f"postgresql+psycopg2://u:{SECRET}@h/db", "asks for the driver 'psycopg2': this "
     "console talks to postgresql with psycopg; write postgresql://…"),
    (f"postgresql://u:{SECRET}@/db", "names no server: write "
     "postgresql://user:password@host:port/database"),
    (f"postgresql://u:{SECRET}@h", "names no database on h: write "
     "postgresql://user:password@host:port/database"),
    (f"postgresql://u:{SECRET}@h:70000/db", "has the port 70000: give one from 1 to 65535 "
     "(PostgreSQL's is 5432)"),
    ("sqlite://", "names no file: write sqlite:////absolute/path/registry.sqlite3"),
    ("sqlite:///:memory:", "names no file: write sqlite:////absolute/path/registry.sqlite3"),
    ("sqlite:///registry.sqlite3", "names the relative path 'registry.sqlite3': give an "
     "absolute one, sqlite:////absolute/path/registry.sqlite3 (four slashes)"),
])
def test_a_url_that_names_no_usable_registry_is_refused(config, data_dir, text, problem):
    path = write(config, text + "\n")
    assert refusal(data_dir) == f"the registry URL in {path} {problem}"


@pytest.mark.parametrize(("content", "problem"), [
    (b"", "holds 0 lines of text, not one URL: write the URL alone on one line, e.g. "
     + EXAMPLES),
    (b"# nothing yet\n", "holds 0 lines of text, not one URL: write the URL alone on one "
     "line, e.g. " + EXAMPLES),
    (b"sqlite:////a.db\npostgresql://h/db\n", "holds 2 lines of text, not one URL: write the "
     "URL alone on one line, e.g. " + EXAMPLES),
    (b"postgresql://h/d\xff", "is not UTF-8 text: write the URL on one line, e.g. "
     + EXAMPLES),
    (b"x" * 5000, "is more than 4096 bytes: it holds one URL, e.g. " + EXAMPLES),
])
def test_a_file_that_holds_no_single_url_is_refused(config, data_dir, content, problem):
    path = write(config, content)
    assert refusal(data_dir) == f"the registry URL file {path} {problem}"
