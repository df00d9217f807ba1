"""A batch export skips a trial it cannot export and lists it, in every format, and goes on
(issue 28 #8: a batch `.mat` export aborted on one damaged trial); `rehab export` then exits
1 with one "not exported" line per trial skipped, as README says (0: all exported, 2: bad
input)."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from app.exports.run import FORMATS
from app.trials.headless import simulate_to_file
from core.trial import THESIS_SUBJECT
from tests.app.cli.running import run


def _events_a_scalar_list(f: h5py.File) -> None:
    del f["events"]
    f["events"] = np.arange(5)


def _channels_a_list_of_numbers(f: h5py.File) -> None:
    del f["channels"]
    f["channels"] = np.arange(3)


def _cut(path) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 3])


@pytest.fixture(scope="module")
def good(tmp_path_factory):
    path = tmp_path_factory.mktemp("good") / "good.h5"
    simulate_to_file(THESIS_SUBJECT.replace(repetitions=1, duration_s=3.0), path)
    return path


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("damage", [_events_a_scalar_list, _channels_a_list_of_numbers, _cut])
def test_a_damaged_trial_is_skipped_listed_and_the_rest_exported(good, tmp_path, capsys,
                                                                  damage, fmt):
    study = tmp_path / "study"
    study.mkdir()
    shutil.copy(good, study / "a_good.h5")
    bad = shutil.copy(good, study / "b_bad.h5")
    if damage is _cut:
        damage(bad)
    else:
        with h5py.File(bad, "r+") as f:
            damage(f)
    out = tmp_path / "out"
    code, stdout, err = run(["export", "--folder", str(study), "--format", fmt, "--output",
                             str(out)], capsys)
    assert code == 1, err
    assert err == ""
    assert "exported 1 trial(s)" in stdout
    skipped = [line for line in stdout.splitlines() if "not exported" in line]
    assert len(skipped) == 1
    assert "b_bad.h5" in skipped[0]
    written = [p.name for p in out.rglob("*") if p.is_file()]
    assert any("a_good" in name or "run-1" in name for name in written)
    assert not any("b_bad" in name for name in written), written
    assert not any(name.startswith(".") for name in written)  # no temporary left
    if fmt == "bids":
        assert sum(name.endswith("_motion.tsv") for name in written) == 1
