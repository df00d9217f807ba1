"""Ctrl+C, SIGTERM and SIGHUP to `rehab gui`'s process group during a trial (issue 28 #5):
the window, the loop and the recorder each get it. Before, the loop and the recorder died
with tracebacks where they stood, the file stayed 'recording' with its cause nowhere, and
the registry listed the trial as still recording. Now the trial stops as a fault naming
the signal (zero torque in that tick), its file is closed `faulted`, the registry row is
finished with that cause before the window closes, and nothing prints a traceback."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.reader import read_trial
from device.recording.ring import RecordRing
from device.safety.faults import Fault

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = Path(__file__).with_name("gui_under_signal.py")

pytestmark = pytest.mark.slow


@pytest.mark.parametrize("name", ["SIGINT", "SIGTERM", "SIGHUP"])
def test_a_stop_signal_to_the_window_s_process_group_stops_and_records_the_trial(
        name, tmp_path):
    data = tmp_path / "data"
    registry = Registry(DataDir(data))
    registry.create_patient("Ada", "Lovelace", body_mass_kg=70.0, upper_arm_m=0.30,
                            forearm_m=0.28, side="right", shoulder_m=(-0.12, 0.73))
    env = {**os.environ, "REHAB_DATA_DIR": str(data),
           "REHAB_CONFIG_DIR": str(tmp_path / "config"), "QT_QPA_PLATFORM": "offscreen"}
    gui = subprocess.Popen([sys.executable, str(SCRIPT)], cwd=ROOT, env=env, text=True,
                           stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                           start_new_session=True)
    try:
        running = json.loads(gui.stdout.readline() or "{}")
        assert running, gui.stderr.read()
        ring = RecordRing.attach(running["ring"])
        try:
            first = ring.write_count
            deadline = time.monotonic() + 60
            while ring.write_count < first + 250:  # half a second of the trial's ticks
                assert time.monotonic() < deadline
                time.sleep(0.01)
            os.killpg(gui.pid, getattr(signal, name))
            code_out = gui.wait(60)
        finally:
            ring.close()
        stderr = gui.stderr.read()
    finally:
        if gui.poll() is None:
            os.killpg(gui.pid, signal.SIGKILL)
            gui.wait(10)
        gui.stdout.close()
        gui.stderr.close()
    assert code_out == 0, stderr
    assert "Traceback" not in stderr, stderr
    trial = registry.trial(running["trial_id"])
    assert trial.status == "faulted"
    assert name in trial.end_reason
    data_file = read_trial(Path(running["path"]))
    assert data_file.status == "faulted"
    fault = next(e for e in data_file.events if e["kind"] == "fault")
    assert fault["values"]["code"] == Fault.ESTOP
    assert fault["values"]["cause"] == f"signal {name}"
    assert name in fault["message"]
    channels = data_file.channels
    latched = np.flatnonzero(channels["fault"] != 0)
    assert latched.size
    assert (channels["torque_applied"][latched] == 0.0).all()
    np.testing.assert_array_equal(channels["tick"], np.arange(len(channels["tick"])))
