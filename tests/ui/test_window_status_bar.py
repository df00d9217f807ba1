"""The status bar at 1366 × 768 (brief hI): with the loop's timing warning and the shared
registry unreachable both shown, each warning is whole (it said "⚠ Timing late: close o"
and "⚠ Shared registry unreachable: recording", cut by the robot's and the trial's words,
which took their whole width first); the robot's and the trial's words give way, cut
with an ellipsis, their whole text in the tooltip and in `text()`."""

import pytest

from tests.ui.session import open_window
from ui import theme
from ui.views.loop_health import WARN_ROBOT, WARN_SIMULATOR
from ui.window.station import LOGIN_REFUSED, SYNC_REFUSED, UNREACHABLE


@pytest.fixture
def window(qtbot, qapp, tmp_path, monkeypatch):
    # the console's theme, as the console runs (ui.gui): without it the test measured Qt's
    # smaller default font when run alone and the theme's after another test had set it
    theme.apply_theme(qapp)
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    win.resize(1366, 738)
    yield win
    win.close()


def _laid_out(win):
    """The status bar laid out for the texts just set, at the window's 1366 px."""
    from PySide6.QtWidgets import QApplication

    bar = win.statusBar()
    QApplication.processEvents()
    bar.layout().activate()
    QApplication.processEvents()
    assert bar.width() == 1366
    return bar


@pytest.mark.parametrize("reach", [UNREACHABLE, LOGIN_REFUSED, SYNC_REFUSED])
@pytest.mark.parametrize("warning", [WARN_SIMULATOR, WARN_ROBOT])
def test_both_warnings_are_whole_beside_long_robot_words(qtbot, window, warning, reach):
    win = window
    win.state_label.setText("<b>Connected</b>")
    robot = "simulator (healthy, a new seed each trial)"
    trial = "session 12, trial 34: stopped by the therapist"
    win.backend_label.setText(robot)
    win.trial_label.setText(trial)
    win.health_label.setText(warning)
    win.registry_label.setText(f"{theme.PROBLEM_SIGN} {reach}")
    bar = _laid_out(win)
    for label in (win.health_label, win.registry_label):
        assert label.width() >= label.sizeHint().width(), (
            f"{label.text()!r} cut: {label.width()} px of {label.sizeHint().width()}")
        assert label.mapTo(bar, label.rect().topLeft()).x() >= 0
        assert label.mapTo(bar, label.rect().topRight()).x() <= bar.width()
    # the robot's words give way, whole in text() (the window reads them back) and the
    # tooltip; the state stays whole
    assert win.state_label.width() >= win.state_label.sizeHint().width()
    assert (win.backend_label.text(), win.trial_label.text()) == (robot, trial)
    labels = (win.state_label, win.backend_label, win.trial_label, win.health_label,
              win.registry_label)
    cut = [label for label in labels[1:3] if label.is_elided()]
    if sum(label.sizeHint().width() for label in labels) > bar.width():
        assert cut, "the words do not fit, yet none of the robot's words gave way"
    for label in cut:
        assert label.shown_text().endswith("…")
        assert label.text().startswith(label.shown_text()[:-1])


def test_the_robot_words_are_whole_when_there_is_room(qtbot, window):
    win = window
    win.backend_label.setText("simulator (healthy, a new seed each trial)")
    win.trial_label.setText("session 1, trial 3: complete")
    win.health_label.setText("Timing OK")
    _laid_out(win)
    for label in (win.backend_label, win.trial_label):
        assert not label.is_elided()
        assert label.shown_text() == label.text()
