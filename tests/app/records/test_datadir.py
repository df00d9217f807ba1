"""Where files live, how they are named, and the daily log files kept there."""

from __future__ import annotations

import datetime
import logging
import os
import pickle
import shutil
import tempfile
import time
import warnings
from pathlib import Path

import platformdirs
import pytest

from app.errors import DataDirError
from app.records import datadir as datadir_module
from app.records.datadir import (
    ENV_DATA_DIR,
    LAYOUT,
    SOURCE_DEFAULT,
    SOURCE_ENVIRONMENT,
    SOURCE_SETTING,
    DataDir,
    check_code,
    locate_data_dir,
    trial_stem,
)
from app.records.logs import (
    LOG_PREFIX,
    DailyFileHandler,
    log_file_for,
    setup_logging,
    shutdown_logging,
)
from app.records.settings import ENV_CONFIG_DIR, Settings, save_settings

UTC = datetime.UTC
STARTED = datetime.datetime(2024, 5, 2, 9, 30, 15, 999_000, tzinfo=UTC)


# -- precedence ------------------------------------------------------------------------------

def test_environment_wins_over_setting_which_wins_over_default(tmp_path):
    env_dir, setting_dir = tmp_path / "env", tmp_path / "setting"
    settings = Settings(data_dir=str(setting_dir))

    chosen = locate_data_dir(settings, {ENV_DATA_DIR: str(env_dir)})
    assert (chosen.root, chosen.source) == (env_dir, SOURCE_ENVIRONMENT)
    chosen = locate_data_dir(settings, {ENV_DATA_DIR: " "})  # empty counts as unset
    assert (chosen.root, chosen.source) == (setting_dir, SOURCE_SETTING)
    chosen = locate_data_dir(Settings(), {})
    assert chosen.source == SOURCE_DEFAULT
    assert chosen.root == platformdirs.user_data_path("rehab-console", appauthor=False)
    assert not env_dir.exists()
    assert not setting_dir.exists()


def test_the_saved_setting_is_read_when_no_settings_are_given(tmp_path, monkeypatch):
    monkeypatch.setenv(ENV_CONFIG_DIR, str(tmp_path / "config"))
    monkeypatch.delenv(ENV_DATA_DIR, raising=False)
    save_settings(Settings(data_dir=str(tmp_path / "chosen")))
    assert locate_data_dir().root == tmp_path / "chosen"
    monkeypatch.setenv(ENV_DATA_DIR, str(tmp_path / "override"))
    assert locate_data_dir().root == tmp_path / "override"


def test_relative_and_home_paths_are_made_absolute_once(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    chosen = locate_data_dir(Settings(), {ENV_DATA_DIR: "clinic-data"})
    assert chosen.root == tmp_path / "clinic-data"
    home = locate_data_dir(Settings(data_dir="~/rehab"), {})
    assert home.root.is_absolute()
    assert "~" not in str(home.root)


# -- folders -----------------------------------------------------------------------------------

def test_layout_is_created_on_demand(tmp_path):
    data = DataDir(tmp_path / "a" / "b")
    assert not data.root.exists()
    assert data.ensure_layout() == data.root
    assert sorted(p.name for p in data.root.iterdir()) == sorted(LAYOUT)
    assert data.registry_path == data.root / "registry.sqlite3"
    assert (data.trials_dir, data.reports_dir, data.exports_dir, data.logs_dir) == tuple(
        data.root / name for name in ("trials", "reports", "exports", "logs"))
    assert list(data.root.rglob(".write-test-*")) == []


def test_a_file_in_the_way_is_named_with_what_to_do(tmp_path):
    blocker = tmp_path / "data"
    blocker.write_text("not a folder")
    with pytest.raises(DataDirError, match=rf"{blocker}.*{ENV_DATA_DIR}"):
        DataDir(blocker).ensure()
    with pytest.raises(DataDirError, match=r"is a file, not a folder.*choose another data folder"):
        DataDir(blocker).ensure("logs")


def test_a_folder_that_refuses_writes_is_reported_with_its_source(tmp_path, monkeypatch):
    def refuse(**kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(datadir_module.tempfile, "mkstemp", refuse)
    data = DataDir(tmp_path / "ro", SOURCE_SETTING)
    with pytest.raises(DataDirError, match=r"cannot write in the data folder .*Permission denied"
                                           r".*came from the setting"):
        data.ensure("trials")


UNPRIVILEGED = 65534  # nobody and nogroup: what a root test drops to


def unprivileged(call, *args):
    """call(*args) as a user that permission bits bind: in this process, unless the tests
    run as root (as in CI), whom the bits do not bind; then in a forked child that drops
    to uid and gid 65534 first. Returns the call's result, or raises its exception here
    (a failed drop raises too, so nothing passes by accident)."""
    if os.geteuid() != 0:
        return call(*args)
    read, write = os.pipe()
    with warnings.catch_warnings():
        # Python 3.12 warns about fork in a threaded process; the child only makes a
        # few system calls and exits, taking no lock another thread could hold.
        warnings.filterwarnings("ignore", r".*multi-threaded.*fork", DeprecationWarning)
        # JAX warns likewise when a test before this one in the same worker loaded it
        # (pytest-xdist deals files out in any order); the child never touches JAX
        warnings.filterwarnings("ignore", r"os\.fork\(\) was called", RuntimeWarning)
        pid = os.fork()
    if pid == 0:  # the child: never returns into pytest
        try:
            os.close(read)
            try:
                os.setgroups([])
                os.setgid(UNPRIVILEGED)
                os.setuid(UNPRIVILEGED)
                outcome = ("returned", call(*args))
            except BaseException as exc:
                outcome = ("raised", exc)
            with os.fdopen(write, "wb") as stream:
                pickle.dump(outcome, stream)
        finally:
            os._exit(0)
    os.close(write)
    with os.fdopen(read, "rb") as stream:
        data = stream.read()
    os.waitpid(pid, 0)
    kind, value = pickle.loads(data)  # EOFError if the child died without a word
    if kind == "raised":
        raise value
    return value


@pytest.fixture
def own_folder(tmp_path):
    """make(name, mode): a folder the user `unprivileged` runs as owns, with `mode`. As
    root it is made where that user can reach it (tmp_path's parents are private)."""
    if os.geteuid() != 0:
        base = tmp_path
    else:
        base = Path(tempfile.mkdtemp(prefix="rehab-unprivileged-"))
        base.chmod(0o755)
    made = []

    def make(name: str, mode: int) -> Path:
        folder = base / name
        folder.mkdir()
        if os.geteuid() == 0:
            os.chown(folder, UNPRIVILEGED, UNPRIVILEGED)
        folder.chmod(mode)
        made.append(folder)
        return folder

    yield make
    for folder in made:
        folder.chmod(0o700)
    if base is not tmp_path:
        shutil.rmtree(base)


def test_a_read_only_folder_is_refused(own_folder):
    folder = own_folder("ro", 0o500)
    with pytest.raises(DataDirError, match="cannot write"):
        unprivileged(DataDir(folder).ensure)
    # The same user, in a folder of theirs they may write in, is not refused: the
    # refusal above is the permission bits', not the test's reach.
    writable = own_folder("rw", 0o700)
    assert unprivileged(DataDir(writable).ensure, "trials") == writable / "trials"


def _counting_probes(monkeypatch) -> list[str]:
    """The folders `DataDir.ensure` probes with a written file from now on."""
    probed: list[str] = []
    mkstemp = datadir_module.tempfile.mkstemp

    def counting(**kwargs):
        probed.append(str(kwargs["dir"]))
        return mkstemp(**kwargs)

    monkeypatch.setattr(datadir_module.tempfile, "mkstemp", counting)
    return probed


def test_a_folder_checked_whole_is_not_checked_again_while_it_stands(tmp_path, monkeypatch):
    """A trial's registration ensures the patient's folder each time: checked whole (the
    root's privacy, the folders above it, a written probe) once a process, then only seen
    to be the same folders with the same owners and modes (docs/performance.md)."""
    probed = _counting_probes(monkeypatch)
    data = DataDir(tmp_path / "data")
    folder = data.ensure("trials", "P000001")
    assert data.ensure("trials", "P000001") == folder
    assert DataDir(tmp_path / "data").ensure("trials", "P000001") == folder
    assert probed == [str(folder)]
    data.ensure("trials", "P000002")  # another folder: checked whole
    assert probed == [str(folder), str(folder.parent / "P000002")]


def test_a_folder_removed_after_its_check_is_made_again(tmp_path, monkeypatch):
    probed = _counting_probes(monkeypatch)
    data = DataDir(tmp_path / "data")
    folder = data.ensure("trials", "P000001")
    shutil.rmtree(folder.parent)
    assert data.ensure("trials", "P000001") == folder
    assert folder.is_dir()
    assert len(probed) == 2
    # replaced by a file: refused, as at the first check
    shutil.rmtree(folder)
    folder.write_text("not a folder")
    with pytest.raises(DataDirError, match="a file of that name is in the way"):
        data.ensure("trials", "P000001")


def test_a_folder_opened_to_others_after_its_check_is_refused(tmp_path):
    """The root, or a folder above it, made writable by others after the check: the next
    ensure checks whole again and refuses, as the first would have."""
    above = tmp_path / "above"
    data = DataDir(above / "data")
    data.ensure("trials")
    os.chmod(data.root, 0o770 | 0o007)
    with pytest.raises(DataDirError, match="can be written by others"):
        data.ensure("trials")
    os.chmod(data.root, 0o700)
    data.ensure("trials")
    os.chmod(above, 0o777)
    try:
        with pytest.raises(DataDirError, match=r"others can write \(mode 777\)"):
            data.ensure("trials")
    finally:
        os.chmod(above, 0o700)


def test_a_folder_made_read_only_after_its_check_is_refused(own_folder):
    """Made read-only (its mode) between two trials: refused at the next registration, as
    at the first; as the user that permission bits bind."""
    folder = own_folder("data", 0o700)

    def twice():
        data = DataDir(folder)
        data.ensure("trials")
        os.chmod(folder / "trials", 0o500)
        try:
            data.ensure("trials")
        finally:
            os.chmod(folder / "trials", 0o700)

    with pytest.raises(DataDirError, match="cannot write in the data folder"):
        unprivileged(twice)


# -- names ---------------------------------------------------------------------------------

def test_trial_files_are_named_from_code_numbers_and_utc_time(tmp_path):
    data = DataDir(tmp_path)
    local = STARTED.astimezone(datetime.timezone(datetime.timedelta(hours=-5)))
    assert trial_stem("P7K2M9Q", 3, 12, local) == "P7K2M9Q_S003_T012_20240502T093015Z"
    assert data.trial_file("P7K2M9Q", 3, 12, STARTED) == (
        "trials/P7K2M9Q/P7K2M9Q_S003_T012_20240502T093015Z.h5")
    assert data.report_path("P7K2M9Q", 3, 12, STARTED) == (
        tmp_path / "reports" / "P7K2M9Q" / "P7K2M9Q_S003_T012_20240502T093015Z.pdf")
    assert data.patient_trials_dir("P7K2M9Q") == tmp_path / "trials" / "P7K2M9Q"


@pytest.mark.parametrize("not_a_code", ["Smith", "P7K2M9", "PIIIIII", "../P7K2M9Q", "p7k2m9q"])
def test_anything_but_a_code_is_refused_for_file_names_without_echoing_it(not_a_code):
    with pytest.raises(DataDirError, match="pseudonymous patient code") as caught:
        check_code(not_a_code)
    assert not_a_code not in str(caught.value)


def test_numbers_and_time_must_be_sound():
    with pytest.raises(DataDirError, match="trial number 0"):
        trial_stem("P7K2M9Q", 1, 0, STARTED)
    with pytest.raises(DataDirError, match="no time zone"):
        trial_stem("P7K2M9Q", 1, 1, STARTED.replace(tzinfo=None))


def test_stored_paths_stay_inside_the_data_folder(tmp_path):
    data = DataDir(tmp_path)
    assert data.resolve("trials/P7K2M9Q/x.h5") == tmp_path / "trials" / "P7K2M9Q" / "x.h5"
    assert data.relative(tmp_path / "trials" / "x.h5") == "trials/x.h5"
    for bad in ("/etc/passwd", "../outside.h5", "trials/../../x", ""):
        with pytest.raises(DataDirError, match="not inside the data folder"):
            data.resolve(bad)
    with pytest.raises(DataDirError, match="outside the data folder"):
        data.relative(tmp_path.parent / "elsewhere.h5")


# -- logs --------------------------------------------------------------------------------------

@pytest.fixture
def clean_logging():
    root = logging.getLogger()
    level = root.level
    yield
    shutdown_logging()
    root.setLevel(level)


def test_setup_logging_writes_todays_file_in_the_data_folder_once(tmp_path, clean_logging):
    data = DataDir(tmp_path / "data")
    before = time.time()
    path = setup_logging(data)
    today = {log_file_for(data.logs_dir, t) for t in (before, time.time())}  # midnight-proof
    assert path in today
    assert path.parent == data.root / "logs"
    assert setup_logging(data) == path  # idempotent
    ours = [h for h in logging.getLogger().handlers if isinstance(h, DailyFileHandler)]
    assert len(ours) == 1
    logging.getLogger("app.test").info("trial %d registered", 7)
    ours[0].flush()
    lines = path.read_text(encoding="utf-8").splitlines()
    assert len(lines) == 1
    assert lines[0].endswith("trial 7 registered")
    assert " INFO app.test " in lines[0]


def test_warnings_go_to_stderr_in_command_line_use(tmp_path, clean_logging, capsys):
    setup_logging(DataDir(tmp_path), stderr=True)
    logging.getLogger("app.test").info("quiet")
    logging.getLogger("app.test").warning("registry busy")
    err = capsys.readouterr().err
    assert "WARNING: registry busy" in err
    assert "quiet" not in err
    setup_logging(DataDir(tmp_path), stderr=False)
    logging.getLogger("app.test").warning("gone")
    assert "gone" not in capsys.readouterr().err


def test_a_new_file_each_day_and_old_days_deleted(tmp_path):
    folder = tmp_path / "logs"
    folder.mkdir()
    day = datetime.datetime(2024, 5, 2, 23, 59, 59).timestamp()
    stale = folder / f"{LOG_PREFIX}2024-01-01.log"  # > 90 days before 2024-05-02
    ageing = folder / f"{LOG_PREFIX}2024-03-01.log"  # > 90 days before 2024-06-02 only
    kept = folder / f"{LOG_PREFIX}2024-04-20.log"
    other = folder / "notes.txt"
    for path in (stale, ageing, kept, other):
        path.write_text("x")

    now = [day]
    handler = DailyFileHandler(folder, keep_days=90, clock=lambda: now[0])
    handler.setFormatter(logging.Formatter("%(message)s"))
    logger = logging.getLogger("test.daily")
    logger.propagate = False
    logger.addHandler(handler)
    logger.setLevel(logging.INFO)
    try:
        assert not stale.exists()
        assert ageing.exists()
        assert kept.exists()
        assert other.exists()
        logger.info("before midnight")
        now[0] = day + 2.0  # 00:00:01 the next day
        logger.info("after midnight")
        now[0] = day + 2.0 + 30 * 86400
        logger.info("a month later")
    finally:
        logger.removeHandler(handler)
        handler.close()
        logger.propagate = True

    read = {p.name: p.read_text().splitlines() for p in folder.glob(f"{LOG_PREFIX}*")}
    assert read[f"{LOG_PREFIX}2024-05-02.log"] == ["before midnight"]
    assert read[f"{LOG_PREFIX}2024-05-03.log"] == ["after midnight"]
    assert read[f"{LOG_PREFIX}2024-06-02.log"] == ["a month later"]
    assert not ageing.exists()
    assert kept.exists()
    assert other.exists()


def test_library_chatter_stays_out_of_the_clinics_log(tmp_path, clean_logging):
    """206 of 218 lines of a day's log were fontTools' INFO when a report was written."""
    path = setup_logging(DataDir(tmp_path / "data"))
    logging.getLogger("fontTools.subset").info("maxp pruned")
    logging.getLogger("matplotlib.font_manager").info("found a font")
    logging.getLogger("fontTools.ttLib").warning("a damaged font table")
    logging.getLogger("app.trials").info("trial 3 finished")
    for handler in logging.getLogger().handlers:
        handler.flush()
    text = path.read_text(encoding="utf-8")
    assert "maxp pruned" not in text
    assert "found a font" not in text
    assert "a damaged font table" in text
    assert "trial 3 finished" in text
