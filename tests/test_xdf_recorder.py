"""The tests' small LabRecorder (tests/xdf_recorder.py) ends a recording cleanly when a
sender has gone before it stops, as LabRecorder does, and writes the clock offsets a
sender on another computer would have given."""

from __future__ import annotations

import time
import uuid

import numpy as np
import pylsl
import pyxdf

from tests.patience import HANG_S
from tests.xdf_recorder import XdfRecorder


def _outlet(source):
    return pylsl.StreamOutlet(pylsl.StreamInfo(source, "EMG", 1, 100.0, pylsl.cf_int16, source))


def _connected(outlet):
    deadline = time.monotonic() + HANG_S
    while not outlet.have_consumers():
        assert time.monotonic() < deadline, "the recorder did not connect"
        time.sleep(0.01)


def test_a_sender_gone_before_the_end_is_recorded_with_what_it_sent(tmp_path):
    """stop() asked the gone sender for a last clock offset: pylsl's LostError."""
    gone, staying = (f"rec-{uuid.uuid4().hex[:10]}" for _ in range(2))
    outlets = {gone: _outlet(gone), staying: _outlet(staying)}
    recorder = XdfRecorder([gone, staying], clocks_ahead={staying: 20.5})
    for outlet in outlets.values():
        _connected(outlet)
        outlet.push_chunk(np.arange(50, dtype=np.int16).reshape(50, 1))
    recorder.wait_for({gone: 50, staying: 50})
    del outlets[gone]
    path = recorder.stop(tmp_path / "gone.xdf")
    streams, _ = pyxdf.load_xdf(str(path), synchronize_clocks=False)
    by_source = {s["info"]["source_id"][0]: s for s in streams}
    np.testing.assert_array_equal(by_source[gone]["time_series"][:, 0], np.arange(50))
    offsets = by_source[staying]["clock_values"]
    assert len(offsets) == 2
    np.testing.assert_allclose(offsets, -20.5, atol=0.01)  # this clock minus the sender's
    del outlets
