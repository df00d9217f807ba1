"""Both BIDS validators, real clients nobody here wrote, pass on an export: the current one
(bids-validator-deno, from PyPI) and the legacy one (bids-validator 1.15, from npm; it
refused every `_motion.json` for its custom keys, code 55). scripts/setup-venv dev installs
both; a missing one fails here with what to run, never skips.

The export holds a live trial (its wall_time counted from Connect: the run's LATENCY column
must start at 0) and a trial with EMG (not a BIDS datatype in 1.9: the result says so in
one line and the CSV export holds it)."""

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from app.exports.run import export_folder, export_trial
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from device.recording.emgfile import write_emg
from tests.trialfiles import edited

VENV = Path(sys.executable).parent.parent
DENO = VENV / "bin" / "bids-validator-deno"
LEGACY = VENV / "node" / "node_modules" / ".bin" / "bids-validator"


@pytest.fixture(scope="module")
def dataset(tmp_path_factory):
    source = tmp_path_factory.mktemp("trials")
    live = source / "P1_S001_T001_20261203T100000Z.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python"), live)
    with edited(live) as f:  # as the loop records it: wall_time from Connect (sealed again)
        f["timeseries"]["wall_time"][:] = f["timeseries"]["wall_time"][:] + 5.0
    with_emg = source / "P1_S001_T002_20261203T100100Z.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1), engine="python", seed=3), with_emg)
    t = np.arange(0.0, 4.0, 1 / 1000.0)
    write_emg(with_emg, names=("EMG1", "EMG2"), muscles=("biceps", "triceps"), rate_hz=1000.0,
              time_s=t, samples=1e-4 * np.column_stack((np.sin(t), np.cos(t))),
              source="csv", clock="file time + offset_s", offset_s=0.0)
    result = export_folder(source, tmp_path_factory.mktemp("bids") / "dataset", format="bids")
    return source, result


def _validator(path: Path) -> Path:
    if not path.exists():
        pytest.fail(f"{path} is missing: run scripts/setup-venv dev (it installs both BIDS "
                    "validators)")
    return path


def test_the_current_bids_validator_finds_no_error(dataset):
    _, result = dataset
    done = subprocess.run([str(_validator(DENO)), "--json", str(result.folder)],
                          capture_output=True, text=True, timeout=600)
    report = json.loads(done.stdout)
    errors = [issue for issue in report["issues"]["issues"] if issue["severity"] == "error"]
    assert not errors, errors[:3]
    assert done.returncode == 0, done.stderr[-2000:]


def test_the_legacy_bids_validator_finds_no_error(dataset):
    _, result = dataset
    if shutil.which("node") is None:
        pytest.fail("Node.js is missing: the legacy BIDS validator runs on it")
    done = subprocess.run([str(_validator(LEGACY)), "--json", str(result.folder)],
                          capture_output=True, text=True, timeout=600)
    report = json.loads(done.stdout[done.stdout.index("{"):])
    assert report["issues"]["errors"] == [], report["issues"]["errors"][:3]
    assert done.returncode == 0, done.stderr[-2000:]


def test_latency_starts_at_the_run_and_emg_is_said_or_exported(dataset, tmp_path):
    source, result = dataset
    runs = sorted(result.folder.glob("sub-*/ses-1/motion/*_motion.tsv"))
    assert len(runs) == 2
    channels = pd.read_csv(str(runs[0]).replace("_motion.tsv", "_channels.tsv"), sep="\t")
    latency = int(np.flatnonzero(channels["type"] == "LATENCY")[0])
    wall = pd.read_csv(runs[0], sep="\t", header=None)[latency]
    assert wall.iloc[0] == 0.0  # the file's counts from Connect, 5 s before
    (scans_file,) = result.folder.glob("sub-*/ses-1/sub-*_ses-1_scans.tsv")
    scans = pd.read_csv(scans_file, sep="\t")
    assert list(scans["trial_status"]) == ["complete", "complete"]
    assert json.loads(scans["trial_parameters"][0])["shape"] == "d"
    assert len(result.notes) == 1
    assert "EMG not exported for 1 run(s)" in result.notes[0]
    assert "BIDS 1.9 has no EMG datatype" in result.notes[0]
    files = export_trial(source / "P1_S001_T002_20261203T100100Z.h5", tmp_path)
    emg = pd.read_csv(files[-1])
    assert files[-1].name.endswith("_emg.csv")
    assert list(emg.columns) == ["time_s", "biceps_V", "triceps_V"]
    assert len(emg) == 4000
