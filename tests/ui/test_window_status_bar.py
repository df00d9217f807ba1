"""The status bar at 1366 × 768 (brief hI): with the loop's timing warning and the shared
registry unreachable both shown, each warning is whole (it said "⚠ Timing late: close o"
and "⚠ Shared registry unreachable: recording", cut by the robot's and the trial's words,
which took their whole width first); the robot's words give way, cut with an ellipsis,
their whole text in the tooltip and in `text()`. The two warnings stand one above the other,
so the trial's words are whole too (they read "sessi…" beside both)."""

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
    win.registry_label.show()  # as the station shows it offline (ui.window.station)
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
    assert win.trial_label.width() >= win.trial_label.sizeHint().width()  # never cut
    labels = (win.state_label, win.backend_label, win.trial_label, win.health_label,
              win.registry_label)
    cut = [win.backend_label] if win.backend_label.is_elided() else []
    # the two warnings stand one above the other: the wider of them takes the width
    needed = sum(label.sizeHint().width() for label in labels[:3]) + max(
        label.sizeHint().width() for label in labels[3:])
    if needed > bar.width():
        assert cut, "the words do not fit, yet the robot's words did not give way"
    for label in cut:
        assert label.shown_text().endswith("…")
        assert label.text().startswith(label.shown_text()[:-1])


def test_the_robot_words_are_whole_when_there_is_room(qtbot, window):
    win = window
    win.backend_label.setText("simulator (healthy, a new seed each trial)")
    win.trial_label.setText("session 1, trial 3: complete")
    win.health_label.setText("Timing OK")
    _laid_out(win)
    assert not win.backend_label.is_elided()
    assert win.backend_label.shown_text() == win.backend_label.text()
    assert win.trial_label.width() >= win.trial_label.sizeHint().width()


@pytest.mark.parametrize("warning", [WARN_SIMULATOR, WARN_ROBOT])
def test_the_session_and_trial_are_whole_beside_both_warnings(qtbot, window, warning):
    """Offline with the timing warning the trial's words read "sessi…" at 1366 px (both
    warnings side by side took 1060 px): they stand one above the other now, and the
    session and trial and the warnings are whole (the robot's words may give way)."""
    win = window
    win.state_label.setText("<b>Connected</b>")
    win.backend_label.setText("simulator (healthy, a new seed each trial)")
    win.trial_label.setText("session 12, trial 104: stopped by the therapist")
    win.health_label.setText(warning)
    win.registry_label.setText(f"{theme.PROBLEM_SIGN} {UNREACHABLE}")
    win.registry_label.show()
    bar = _laid_out(win)
    for label in (win.state_label, win.trial_label, win.health_label, win.registry_label):
        assert label.width() >= label.sizeHint().width()
        assert label.mapTo(bar, label.rect().topRight()).x() <= bar.width()
    # one above the other, each line whole in the bar's height
    assert win.registry_label.mapTo(bar, win.registry_label.rect().topLeft()).y() >= \
        win.health_label.mapTo(bar, win.health_label.rect().bottomLeft()).y()
    assert win.registry_label.mapTo(bar, win.registry_label.rect().bottomLeft()).y() < \
        bar.height()


def test_online_the_bar_is_one_line_high(qtbot, window):
    win = window
    win.health_label.setText("Timing OK")
    bar = _laid_out(win)
    assert win.registry_label.isHidden()
    assert bar.height() < 2 * win.health_label.sizeHint().height()
