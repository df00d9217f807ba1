"""The data folder is private to its user (0700 folders, 0600 files) whatever the umask
and whatever an earlier console left: the registry (names, birth years), its journal and
backups, trial files, reports and logs."""

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
    root.mkdir(mode=0o755)
    (root / "trials").mkdir(mode=0o755)  # left open by an earlier console
    registry = Registry(DataDir(root))
    code = registry.create_patient("Ada", "Example", birth_year=1950, body_mass_kg=91.0).code
    params = THESIS_SUBJECT.replace(repetitions=1)
    begun = registry.begin_trial(code, params, backend="simulator")
    save(simulate(params), begun.path, subject_code=code)
    finalize_trial(registry, begun.trial_id)
    report = report_for_registry_trial(registry, begun.trial_id)
    registry.backup(root / "copy.sqlite3")
    handler = DailyFileHandler(registry.data_dir.ensure("logs"))
    handler.close()
    folders = [p for p in [root, *root.rglob("*")] if p.is_dir()]
    files = [p for p in root.rglob("*") if p.is_file()]
    assert {root / "trials", report.parent, begun.path.parent} <= set(folders)
    assert {begun.path, report, root / "registry.sqlite3"} <= set(files)
    for folder in folders:
        assert mode(folder) == 0o700, folder
    for path in files:
        assert mode(path) == 0o600, path
