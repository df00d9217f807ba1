"""The data folder is private to its user (0700 folders, 0600 files) whatever the umask
and whatever an earlier console left inside it: the registry (names, birth years), its
journal and backups, trial files, reports and logs. A folder the console did not make is
never changed: a data folder others can write is refused, not chmodded (issue 28 #10)."""

import os
import stat

import pytest

from app.records.datadir import DataDir
from app.records.logs import DailyFileHandler
from app.records.registry import Registry
from app.reports.build import report_for_registry_trial
from app.trials.finalize import finalize_trial
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT


def mode(path) -> int:
    return stat.S_IMODE(os.stat(path).st_mode)


@pytest.fixture
def open_umask():
    old = os.umask(0o022)  # the common default: everyone may read what is created
    yield
    os.umask(old)


def test_every_folder_and_file_of_the_data_folder_is_its_users_only(tmp_path, open_umask):
    root = tmp_path / "data"
    root.mkdir(mode=0o755)  # the user's own folder, readable by others: left as it is
    (root / "trials").mkdir(mode=0o755)  # left open by an earlier console
    registry = Registry(DataDir(root))
    code = registry.create_patient("Ada", "Example", birth_year=1950, body_mass_kg=91.0).code
    params = THESIS_SUBJECT.replace(repetitions=1)
    begun = registry.begin_trial(code, params, backend="simulator")
    save(simulate(params), begun.path, subject_code=code)
    finalize_trial(registry, begun.trial_id)
    report = report_for_registry_trial(registry, begun.trial_id)
    registry.backup(registry.data_dir.ensure("exports") / "copy.sqlite3")
    handler = DailyFileHandler(registry.data_dir.ensure("logs"))
    handler.close()
    folders = [p for p in [root, *root.rglob("*")] if p.is_dir()]
    files = [p for p in root.rglob("*") if p.is_file()]
    assert {root / "trials", report.parent, begun.path.parent} <= set(folders)
    assert {begun.path, report, root / "registry.sqlite3"} <= set(files)
    assert mode(root) == 0o755  # not the console's to change
    for folder in folders:
        if folder != root:
            assert mode(folder) == 0o700, folder
    for path in files:
        assert mode(path) == 0o600, path


def test_a_data_folder_the_console_makes_is_private_at_every_level(tmp_path, open_umask):
    root = tmp_path / "new" / "data"
    Registry(DataDir(root))
    assert mode(root) == mode(root.parent) == 0o700
    assert mode(root / "registry.sqlite3") == 0o600


@pytest.mark.parametrize("bits", [0o1777, 0o777, 0o775, 0o757])
def test_a_folder_others_can_write_is_refused_and_left_as_it_was(tmp_path, bits, capsys):
    """`rehab --data-dir /tmp patients` once chmodded /tmp to 0700 and took its sticky bit
    (as root, everyone lost /tmp): a folder others (or a shared group) can write is refused
    in one line, never changed, and nothing is created in it."""
    from tests.app.cli.running import run

    shared = tmp_path / "shared"
    shared.mkdir()
    group = shared.stat().st_gid
    if bits & 0o020 and not bits & 0o002:
        os.chown(shared, -1, 65534)  # nogroup: a group of others
    os.chmod(shared, bits)
    for argv in (["patients"], ["patients", "add", "--first-name", "A"], ["trials", "P0000000"],
                 ["run", "--code", "P0000000", "--repetitions", "1", "--duration", "3"]):
        code, _, err = run(["--data-dir", str(shared), *argv], capsys)
        assert code == 2, argv
        assert err.count("\n") == 1, err
        assert "can be written by others" in err or "no registry" in err, err
        if "can be written by others" in err:  # what to do, with names as they are typed
            assert f"(chmod 700 {shared})" in err
            assert "REHAB_DATA_DIR" in err  # str.capitalize() once made it rehab_data_dir
        assert stat.S_IMODE(shared.stat().st_mode) == bits
        assert list(shared.iterdir()) == []
    os.chown(shared, -1, group)


def test_a_folder_on_a_path_others_can_swap_is_refused(tmp_path):
    """A private folder inside a folder everyone can write (without the sticky bit) can be
    renamed away and replaced by another user's: refused."""
    from app.errors import DataDirError

    open_parent = tmp_path / "open"
    open_parent.mkdir()
    os.chmod(open_parent, 0o777)
    with pytest.raises(DataDirError, match=r"others can write \(mode 777\)"):
        DataDir(open_parent / "data").ensure()
    os.chmod(open_parent, 0o1777)  # sticky, as /tmp: only the owner may rename
    DataDir(open_parent / "data").ensure()
