"""After a trial the window's tabs show the trial as its file holds it, not the live
display it fed while the trial ran (that display misses what the ring skipped under load
and records that came before the window heard the trial start)."""

import numpy as np
import pytest

from app.trials.reader import read_trial
from tests.ui.session import build_connect_start, open_window, register_patient, short_trial

pytestmark = pytest.mark.slow


def test_the_finished_trial_is_shown_from_its_file(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
        build_connect_start(qtbot, win)
        live = win.live
        qtbot.waitUntil(lambda: win.unsaved_trial is not None and win.live is not live)
        path = win.registry.trial_path(win.registry.trial(win.unsaved_trial))
        data = read_trial(path)
        view = win.live
        assert view.source == path
        assert view.finished
        assert win.shown_view is view
        assert view.parameters is win.built  # the patient's screen still shows the trial
        np.testing.assert_array_equal(view.time[:view.n], data.time[:view.n])
        assert view.n == min(data.n_samples, view.max_samples)
        assert view.metrics.keys() == data.metrics.keys()
        np.testing.assert_array_equal(list(view.metrics.values()),
                                      [data.metrics[k] for k in view.metrics])
    finally:
        win.close()
