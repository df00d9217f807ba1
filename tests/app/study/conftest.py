"""A generated study (trial files of the console's own headless simulator, in a
multi-site layout, with a damaged file and files that are not trials) and one local Dask
cluster of two worker processes for the module's tests."""

from __future__ import annotations

import datetime
import shutil
from pathlib import Path

import h5py
import numpy as np
import pytest

from app.records.datadir import trial_stem
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT

D = THESIS_SUBJECT.replace(repetitions=1)
CIRCLE = D.replace(shape="circle", radius_m=0.07, assist="as-needed")
PATIENTS = {"P1ZTTAQ": "north", "P2ABCDE": "north", "P3XYZ12": "south"}
"""Three patients at two sites; each has three trials (two exercises)."""
SOUND = 9
START = datetime.datetime(2026, 3, 2, 9, 0, tzinfo=datetime.UTC)


def make_trial(folder: Path, code: str, session: int, number: int, parameters, seed: int
               ) -> Path:
    """A console-named trial file of the simulator's healthy virtual patient."""
    started = START + datetime.timedelta(days=session, minutes=number)
    path = folder / f"{trial_stem(code, session, number, started)}.h5"
    path.parent.mkdir(parents=True, exist_ok=True)
    save(simulate(parameters, patient="healthy", seed=seed), path, subject_code=code)
    return path


@pytest.fixture(scope="session")
def study(tmp_path_factory) -> Path:
    """SITE/PATIENT/<code>_S00s_T00n_<UTC>.h5 for every patient, then in the folder's top:
    a truncated copy of a trial, an HDF5 file that is not a trial and a text file named
    .h5. The sound files are SOUND."""
    root = tmp_path_factory.mktemp("study")
    seed = 0
    for code, site in PATIENTS.items():
        for session, number, parameters in ((1, 1, D), (1, 2, CIRCLE), (2, 1, D)):
            seed += 1
            make_trial(root / site / code, code, session, number, parameters, seed)
    first = next((root / "north" / "P1ZTTAQ").glob("*.h5"))
    data = first.read_bytes()
    (root / "truncated.h5").write_bytes(data[: len(data) // 3])
    with h5py.File(root / "other.h5", "w") as f:
        f["x"] = np.arange(3)
    (root / "notes.h5").write_text("not a trial at all\n")
    return root


@pytest.fixture(scope="session")
def client():
    """A local cluster as `rehab study analyse` starts it (two processes of one thread, on
    127.0.0.1, no dashboard), for the session's tests."""
    from app.study.cluster import study_client

    with study_client() as client:
        yield client


@pytest.fixture
def copy_of(tmp_path):
    """A copy of a folder, for a test that changes it."""
    def copy(folder: Path) -> Path:
        target = tmp_path / folder.name
        shutil.copytree(folder, target)
        return target
    return copy
