"""The patient's screen shows the target and the hand where the trial file says they were,
and "Go!" at the exercise phase's first sample (issue 30, the patient's screen).

A short trial runs headless on the simulator into a real trial file; its samples are fed
back through a TrialView in batches as the window's repaint timer feeds the live view, and
after each batch the patient's window shows the newest sample: the view model's cursor and
target must be the file's position and desired position at that sample (robot frame, m),
and the painted pixels must be where the placement puts them, in the cursor's colour.
"""

import numpy as np
import pytest
from PySide6.QtGui import QColor

from app.trials.headless import simulate_to_file
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PHASE_APPROACH, PHASE_EXERCISE
from device.recording.record import RECORD_DTYPE
from ui.patient.window import CURSOR, GO, PatientWindow
from ui.views.patient_screen import CUE_DONE, CUE_GO, CUE_READY, GO_SHOWN_S
from ui.views.trialview import VIEW_CHANNELS, TrialView

BATCH = 37  # ticks per batch: not a divisor of anything in the trial


@pytest.fixture(scope="module")
def trial_file(tmp_path_factory):
    path = tmp_path_factory.mktemp("patient") / "trial.h5"
    params = THESIS_SUBJECT.replace(repetitions=2, duration_s=2.0, assist="as-needed")
    simulate_to_file(params, path, patient="weak", seed=3)
    return read_trial(path)


def _records(data) -> np.ndarray:
    dtype = np.dtype([(c, RECORD_DTYPE.fields[c][0]) for c in VIEW_CHANNELS])
    records = np.zeros(data.n_samples, dtype=dtype)
    for name in VIEW_CHANNELS:
        records[name] = data.channels[name]
    return records[records["phase"] > 0]  # what the window's live view is given


def _batches(phase: np.ndarray):
    """Batch ends: every BATCH ticks, and one ending at the last approach sample and one
    at the exercise's first, as a repaint could fall."""
    first = int(np.flatnonzero(phase == PHASE_EXERCISE)[0])
    ends = set(range(BATCH, len(phase), BATCH)) | {first, first + 1, len(phase)}
    return sorted(ends - {0}), first


def _colour_at(image, point) -> QColor:
    return image.pixelColor(round(point[0]), round(point[1]))


def test_the_screen_shows_the_hand_and_target_where_the_file_says(qtbot, trial_file):
    data = trial_file
    records = _records(data)
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(900, 700)
    window.show()
    view = TrialView(data.parameters)
    ends, first = _batches(records["phase"])
    t_go = float(records["time"][first])
    start = 0
    checked = painted = 0
    seen_go = seen_done = False
    for end in ends:
        view.append(records[start:end])
        start = end
        window.show_view(view)
        i = end - 1  # the newest sample, the one a live screen shows
        frame = window.frame
        assert frame.sample == view.n - 1
        np.testing.assert_array_equal(frame.cursor_m, records["position"][i])
        np.testing.assert_array_equal(frame.target_m, records["position_desired"][i])
        checked += 1
        phase = records["phase"][i]
        t = float(records["time"][i])
        if phase == PHASE_APPROACH:
            assert frame.cue == CUE_READY
            assert not frame.go
            assert frame.time_left_s == pytest.approx(4.0)
        elif phase == PHASE_EXERCISE:
            assert frame.go == (t - t_go < GO_SHOWN_S)
            assert frame.time_left_s == pytest.approx(max(0.0, 4.0 - (t - t_go)))
            assert frame.repetition == min(2, int((t - t_go) // 2.0) + 1)
            seen_go |= frame.go
        else:
            assert frame.cue == CUE_DONE
            seen_done = True
        if end in (first, first + 1) or checked % 9 == 0:
            image = window.grab().toImage()  # paints now
            where = window.placement()
            expected = where.to_px(records["position"][i])
            np.testing.assert_allclose(window.painted["cursor"], expected, atol=1e-9)
            np.testing.assert_allclose(
                window.painted["target"], where.to_px(records["position_desired"][i]),
                atol=1e-9)
            np.testing.assert_allclose(where.to_table(expected), records["position"][i],
                                       atol=1e-12)
            assert _colour_at(image, expected) == CURSOR
            painted += 1
        if end == first:  # the last approach sample: not yet
            assert not frame.go
            assert frame.cue == CUE_READY
        if end == first + 1:  # the exercise's first sample: Go, in green
            assert frame.go
            assert frame.cue == CUE_GO
            band = window.screen_layout().bottom
            strip = [image.pixelColor(x, round(band.top + band.height / 2))
                     for x in range(0, window.width(), 2)]
            assert GO in strip
    assert seen_go
    assert seen_done
    assert checked > 50
    assert painted > 5


def test_a_replay_shows_each_moment_the_slider_picks(qtbot, trial_file):
    """The same screen fed from the file as a replay (the view's cursor): the frame is the
    sample at or before the picked time."""
    data = trial_file
    view = TrialView.from_trial(data)
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(640, 480)
    rng = np.random.default_rng(5)
    for t in rng.uniform(data.time[0], data.time[-1], 25):
        view.cursor = float(t)
        window.show_view(view)
        i = int(np.searchsorted(data.time, t, side="right")) - 1
        np.testing.assert_array_equal(window.frame.cursor_m, data.channels["position"][i])
        np.testing.assert_array_equal(window.frame.target_m,
                                      data.channels["position_desired"][i])
