"""What the window says to the therapist and where (issue 27, the window's side of #9–#16):
hands off the handle at Connect; the proposal in view and offered after a restart; file
dialogs in the patient's folder; plain units and whole trials on the axes; every tab usable
on a laptop's screen and at font scale 1.5; plain words (timing, no shell commands, a replay
that says it is one); Registration showing what was just done and a greyed Build saying why
on every tab; the simulator's seed."""

from __future__ import annotations

import contextlib
import datetime
from pathlib import Path
from types import SimpleNamespace

import pytest
from PySide6.QtCore import QPoint
from PySide6.QtGui import QFont, QFontMetrics
from PySide6.QtWidgets import QApplication, QLabel, QWidget

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.progression import propose
from core.trial import TrialParameters
from device.loop.states import State
from tests.ui.session import click, enabled, open_window, register_patient, short_trial
from ui import theme
from ui.main_window import MainWindow


@pytest.fixture
def idle_window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    yield win
    win.close()


@contextlib.contextmanager
def window_at(qtbot, tmp_path, monkeypatch, scale: float, size: tuple[int, int]):
    """An idle window (no loop) at font scale `scale`, sized `size` and on screen; the
    theme's scale back to 1 after, whatever happened."""
    app = QApplication.instance()
    theme.apply_theme(app, scale)
    try:
        win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
        win.resize(*size)
        qtbot.waitExposed(win)
        yield win
    finally:
        theme.apply_theme(app, 1.0)


def _in_view(area, widget: QWidget) -> bool:
    """`widget` lies whole inside the scroll area's visible part."""
    top_left = widget.mapTo(area.viewport(), QPoint(0, 0))
    return area.viewport().rect().contains(top_left) and area.viewport().rect().contains(
        top_left + QPoint(widget.width() - 1, widget.height() - 1))


# -- #9: hands off the handle at Connect -------------------------------------------------
@pytest.mark.slow
def test_connect_to_the_robot_says_hands_off_the_handle_first(qtbot, tmp_path, monkeypatch):
    """On the robot (the example settings: no card here, so its Connect fails after) the
    message line says hands off the handle the moment Connect is pressed, before the force
    sensor takes its zero."""
    from ui.window.trial import HANDS_OFF

    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        short_trial(win)
        p = win.parameters_tab
        p.hardware.setChecked(True)
        p.settings_path.setText(str(Path(__file__).parents[2] / "resources"
                                    / "hardware.example.toml"))
        p.refresh()
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=60000)
        said = []
        win.messages.say = _recording(win.messages.say, said)
        click(qtbot, win.robot.buttons["connect"])
        assert said[0] == HANDS_OFF
        qtbot.waitUntil(lambda: "connect" in enabled(win) or win.state != State.BUILT,
                        timeout=60000)  # the card's absence answered
    finally:
        win.close()


@pytest.mark.slow
def test_the_simulator_never_says_hands_off_and_a_zero_under_load_in_one_line(
        qtbot, tmp_path, monkeypatch):
    """On the simulator nobody holds a handle: Connect and a Build while connected (which
    opens the simulator again, a plan's every block) say what happens, never "Hands off the
    handle" nor that the patient may hold it now. The simulator's zero still refuses a
    simulated push at Connect in one line (what the robot's does)."""
    import ui.window.trial as window_trial
    from device.loop.messages import BackendConfig

    push = {"at": (3.0, 0.0)}  # a hand on the handle at the first Connect

    def config(**kwargs):
        return BackendConfig(**kwargs, push_at_connect_N=push["at"])

    monkeypatch.setattr(window_trial, "BackendConfig", config)
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        short_trial(win)
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=60000)
        said = []
        win.messages.say = _recording(win.messages.say, said)
        click(qtbot, win.robot.buttons["connect"])
        assert said[0] == "Connecting the simulator…"
        qtbot.waitUntil(lambda: "zero was taken with a force" in win.message.toolTip(),
                        timeout=60000)
        assert win.message.toolTip().endswith("Take the hands off the handle and connect "
                                              "again.")
        assert "\n" not in win.message.toolTip()  # one line
        assert win.state == State.BUILT
        push["at"] = (0.0, 0.0)
        click(qtbot, win.robot.buttons["build"])  # the robot's config comes with Build
        qtbot.waitUntil(lambda: win.state == State.BUILT and "Trial built" in
                        win.message.text(), timeout=60000)
        said.clear()
        click(qtbot, win.robot.buttons["connect"])
        qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)
        assert said[0] == "Connecting the simulator…"
        assert win.message.text().startswith("Connected to the simulator. ")
        # built again while connected: the simulator is opened again, with a new zero
        short_trial(win)
        win.parameters_tab.radius.setValue(9.0)
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: "Trial built" in win.message.text(), timeout=60000)
        assert win.state == State.CONNECTED
        assert not [t for t in said if "handle" in t.lower() or "zero taken" in t.lower()]
    finally:
        win.close()


@pytest.mark.slow
def test_connect_pressed_twice_while_the_zero_is_taken_still_says_zero_taken(
        qtbot, tmp_path, monkeypatch):
    """Found trying the window: Connect stayed green during the zero; pressed again, the
    loop refused it and "connect refused: already connected" took the message line in
    place of "Zero taken", the word that tells the patient to take the handle."""
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        short_trial(win)
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=60000)
        said, sent = [], []
        win.messages.say = _recording(win.messages.say, said)
        connect = win.bridge.connect
        monkeypatch.setattr(win.bridge, "connect", lambda: (sent.append(1), connect()))
        click(qtbot, win.robot.buttons["connect"])
        assert not win.robot.buttons["connect"].isEnabled()  # its answer not back yet
        win.connect_robot()  # F3 again
        qtbot.waitUntil(lambda: win.state == State.CONNECTED and any(
            t.startswith("Connected to the simulator") for t in said), timeout=60000)
        assert sent == [1]  # the second press sent nothing to be refused
        assert not [t for t in said if "refused" in t]
        # (the simulator's word for "Zero taken", which the robot says at this moment)
        assert win.message.text().startswith("Connected to the simulator. ")
    finally:
        win.close()


def _recording(say, said: list):
    def recorded(text, **kwargs):
        said.append(text)
        return say(text, **kwargs)
    return recorded


# -- #10: the proposal stays in view and survives a restart -----------------------------
def test_the_proposal_waiting_is_offered_after_a_restart(qtbot, tmp_path, monkeypatch):
    """The registry held the proposal as pending; the window forgot it at a restart."""
    monkeypatch.setenv("REHAB_CONFIG_DIR", str(tmp_path / "config"))
    registry = Registry(DataDir(tmp_path / "data", "test"))
    patient = registry.create_patient("Ada", "Lovelace", body_mass_kg=70.0)
    built = TrialParameters(assist="as-needed", assistance_level=0.8)
    begun = registry.begin_trial(patient.code, built, backend="simulator")
    registry.finish_trial(begun.trial_id, "complete", {"led_pct": 88.0},
                          datetime.datetime.now(datetime.UTC))
    proposal = propose(built, {"led_pct": 88.0}, "complete")
    registry.record_proposal(begun.trial_id, proposal.to_dict())
    win = MainWindow(registry, settings_path=tmp_path / "config" / "settings.json")
    qtbot.addWidget(win)
    win.resize(1366, 738)
    win.show()
    win.tabs.setCurrentWidget(win.parameters_tab)
    win.registration_tab.choose(patient)
    qtbot.waitUntil(lambda: win.patient is not None and not win.reading_after, timeout=60000)
    box = win.parameters_tab.proposal
    assert box.isVisible()
    assert box.proposal == proposal
    assert "After trial 1 of session 1" in box.text.text()
    # in view whatever the form's scroll: it is not in the form
    form_scroll = win.parameters_tab.findChildren(type(win.registration_tab.forms_scroll))[0]
    form_scroll.verticalScrollBar().setValue(form_scroll.verticalScrollBar().maximum())
    assert box.isVisible()
    assert not form_scroll.widget().isAncestorOf(box)
    win.close()


# -- #11: file dialogs start in the patient's folder ------------------------------------
def test_every_file_dialog_starts_in_the_patients_folder(qtbot, idle_window, monkeypatch):
    from PySide6.QtWidgets import QFileDialog

    win = idle_window
    patient = win.registry.create_patient("Ada", "Lovelace", body_mass_kg=70.0)
    win.registration_tab.choose(patient)
    qtbot.waitUntil(lambda: win.patient is not None, timeout=60000)
    starts = {}

    def opened(title):
        def dialog(_parent, caption, start, *_args, **_kwargs):
            starts[title] = start
            return "", ""
        return dialog

    monkeypatch.setattr(QFileDialog, "getSaveFileName", opened("save"))
    monkeypatch.setattr(QFileDialog, "getOpenFileName", opened("open"))
    data = win.registry.data_dir
    trials = data.trials_dir / patient.code
    win.report._content = SimpleNamespace(source=trials / "P_S001_T001.h5")
    win.report._choose_pdf()
    assert Path(starts["save"]) == data.reports_dir / patient.code / "P_S001_T001.pdf"
    for choose in (win.replay._choose_file, win.angles.choose_reference):
        starts.clear()
        choose()
        assert Path(starts["open"]) == trials
    assert (data.reports_dir / patient.code).is_dir()
    starts.clear()
    win.parameters_tab.robot_choice._choose_settings()  # the robot's file: the data folder
    assert Path(starts["open"]) == data.root


# -- #12: plain units, whole trials --------------------------------------------------------
def test_axes_have_plain_units_and_the_emg_tab_shows_the_whole_trial(qtbot, tmp_path):
    from app.emg.subjects import Subject, record_trial
    from app.trials.reader import read_trial
    from ui.tabs.emg import EmgTab
    from ui.tabs.torques import TorquesTab
    from ui.views.trialview import TrialView

    theme.apply_theme(QApplication.instance())
    path = tmp_path / "t.h5"
    subject = Subject.drawn(2)
    record_trial(path, subject, seed=0, engine="python")
    view = TrialView.from_trial(read_trial(path))
    torques = TorquesTab()
    qtbot.addWidget(torques)
    torques.show()
    torques.show_view(view)
    qtbot.waitExposed(torques)
    axis = torques.plot.getPlotItem().getAxis("left")
    axis.setRange(-0.0005, 0.0005)  # values of a milli-newton-metre
    assert "x0.001" not in axis.labelString()
    assert axis.labelString().count("(") == 1  # "torque (N·m)" and nothing after
    emg = EmgTab()
    qtbot.addWidget(emg)
    emg.show()
    emg.show_view(view)
    (low, high), _ = emg.torques.getPlotItem().getViewBox().viewRange()
    assert low == pytest.approx(float(view.time[0]), abs=1e-6)
    assert high == pytest.approx(float(view.time[-1]), abs=1e-6)


# -- #13: every tab usable on a laptop and at font scale 1.5 ------------------------------
@pytest.mark.parametrize(("scale", "size"), [(1.0, (1366, 738)), (1.5, (1920, 1050))])
def test_every_tab_is_whole_on_a_laptop_and_at_a_large_font(qtbot, tmp_path, monkeypatch,
                                                            scale, size):
    """At 1.5 the e-stop read "MERGENCY STO" and four tabs hid behind scroll arrows; at
    1366 × 768 the error plot's label was cut and legends lay over the data."""
    import pyqtgraph as pg

    with window_at(qtbot, tmp_path, monkeypatch, scale, size) as win:
        assert win.width() <= size[0]
        assert win.height() <= size[1]
        estop = win.robot.estop
        font = QFont(estop.font())
        font.setPointSizeF(14.9 * scale)
        font.setBold(True)
        assert QFontMetrics(font).horizontalAdvance("EMERGENCY STOP") < estop.contentsRect().width()
        bar = win.tabs.tabBar()
        assert not bar.usesScrollButtons()
        last = bar.tabRect(bar.count() - 1)
        assert last.right() <= bar.width()  # the last tab whole, in view
        for index in range(win.tabs.count()):
            win.tabs.setCurrentIndex(index)
            QApplication.processEvents()
            tab = win.tabs.currentWidget()
            title = win.tabs.tabText(index)
            for label in tab.findChildren(QLabel):
                if (label.isVisible() and label.text() and not label.wordWrap()
                        and label.sizePolicy().horizontalPolicy().name != "Ignored"):
                    assert label.width() >= label.minimumSizeHint().width(), (title,
                                                                              label.text())
            for plot in tab.findChildren(pg.PlotWidget):
                if not plot.isVisible():
                    continue
                item = plot.getPlotItem()
                if item.legend is not None:  # above the data, not on it
                    assert item.legend.parentItem() is not item.vb, title
                left = item.getAxis("left")
                if left.isVisible() and left.labelText:
                    text = left.label.boundingRect().width()  # drawn turned by 90°
                    assert text <= left.geometry().height() + 1, (title, left.labelText)
        win.close()


# -- #14: plain words --------------------------------------------------------------------
@pytest.mark.parametrize("width", [420, 560, 700, 900])  # each key fits a line
def test_the_reach_pictures_keys_are_never_split_over_two_lines(qtbot, width):
    """At 1366 × 768 the key under "What can be reached" broke between "■" and "robot
    motors", and at font 1.5 between "●" and "shoulder": a sign at a line's end read as
    the key of the words on the next line."""
    from PySide6.QtGui import QTextDocument

    from core.robot import RobotModel
    from ui.reach_preview import ReachPreview

    preview = ReachPreview(RobotModel())
    qtbot.addWidget(preview)
    document = QTextDocument()
    document.setDefaultFont(preview.legend.font())
    document.setHtml(preview.legend.text())
    document.setTextWidth(width)
    document.size()  # lays the text out at that width
    layout = document.firstBlock().layout()
    text = document.toPlainText().replace("\u00a0", " ")  # the same positions
    assert document.blockCount() == 1
    lines = set()
    for sign, words in (("■", "robot can reach"), ("- - -", "arm reaches comfortably"),
                        ("——", "path"), ("✕", "cannot be reached"), ("●", "shoulder"),
                        ("■", "robot motors"), ("▲", "start")):
        start = text.index(f"{sign} {words}")
        end = start + len(sign) + 1 + len(words) - 1
        first = layout.lineForTextPosition(start).lineNumber()
        assert layout.lineForTextPosition(end).lineNumber() == first, (sign, words, width)
        lines.add(first)
    assert len(lines) > 1 or width >= 900  # the narrow widths did wrap: the test saw breaks


def test_no_shell_command_anywhere_in_the_window(qtbot, idle_window):
    win = idle_window
    words = []
    for widget in win.findChildren(QWidget):
        text = getattr(widget, "text", None)
        for said in ((text() if callable(text) else ""), widget.toolTip()):
            if isinstance(said, str):
                words.append(said)
    words.append(win.instructions.plain_text())
    for text in words:
        assert "rehab " not in text, text
        assert "`" not in text, text


@pytest.mark.slow
def test_a_replay_says_which_trial_and_moment_and_is_not_a_live_one(qtbot, tmp_path,
                                                                   idle_window):
    from app.trials.headless import save, simulate

    win = idle_window
    path = tmp_path / "P1ZTTAQ_S002_T003_20261203T101502Z.h5"
    save(simulate(TrialParameters(assist="as-needed", repetitions=1), seed=3), path)
    win.tabs.setCurrentWidget(win.replay)
    with qtbot.waitSignal(win.replay.view_loaded, timeout=20000):
        win.replay.open_file(path)
    assert win.replay_strip.isVisible()
    line = win.replay_text.text()
    assert line.startswith("Replay, not live: P1ZTTAQ, session 2, trial 3,")
    assert "at 0.0 s of" in line
    win.replay.set_cursor(2.5)
    win._on_cursor(2.5)
    assert "at 2.5 s of" in win.replay_text.text()
    win.tabs.setCurrentWidget(win.force)
    assert win.replay_strip.isVisible()
    win.tabs.setCurrentWidget(win.registration_tab)
    assert not win.replay_strip.isVisible()  # only over what shows the trial
    assert not win.back_to_live.isVisible()  # no live trial to go back to


# -- #15: Registration shows the result; a greyed Build says why on every tab ----------
def test_registration_shows_what_was_just_done(qtbot, tmp_path, monkeypatch):
    theme.apply_theme(QApplication.instance())
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    win.resize(1366, 738)
    qtbot.waitExposed(win)
    register_patient(qtbot, win)
    tab = win.registration_tab
    area = tab.forms_scroll
    qtbot.waitUntil(lambda: _in_view(area, tab.patient_label), timeout=2000)
    assert "Lovelace" in tab.patient_label.text()
    assert _in_view(area, tab.measurements_label)
    assert "Stored: body mass 70.0 kg" in tab.measurements_label.text()
    # a namesake: the refusal where the therapist is looking
    qtbot.keyClicks(tab.first_name, "Ada")
    qtbot.keyClicks(tab.last_name, "Lovelace")
    area.verticalScrollBar().setValue(0)
    click(qtbot, tab.create_button)
    qtbot.waitUntil(tab.create_problem.isVisible, timeout=60000)  # the registry's answer
    qtbot.waitUntil(lambda: _in_view(area, tab.create_problem), timeout=2000)
    assert "Already registered" in tab.create_problem.text()
    win.close()


@pytest.mark.parametrize(("scale", "size"), [(1.0, (1366, 738)), (1.5, (1920, 1050))])
def test_a_greyed_build_says_why_on_every_tab_in_whole_words(qtbot, tmp_path, monkeypatch,
                                                             scale, size):
    """The line under the robot buttons was cut with "…" on a laptop and at font scale
    1.5 ("… this arm reaches 58.5 cm. …"): what to do was lost."""
    with window_at(qtbot, tmp_path, monkeypatch, scale, size) as win:
        why = win.robot.why
        one_line = why.height()
        p = win.parameters_tab
        p.shoulder_x.setValue(12.0)  # out of the arm's reach
        p.refresh()
        assert "build" not in enabled(win)
        for index in range(win.tabs.count()):
            win.tabs.setCurrentIndex(index)
            QApplication.processEvents()
            assert why.isVisible()
            assert "Build needs the form fixed" in why.whole
            assert "67.6 cm from the shoulder" in why.toolTip()
            assert why.text() == why.whole  # every word shown, nothing cut with "…"
            assert why.text().endswith("Move the exercise or the shoulder closer together.")
            assert why.wordWrap()
            assert why.height() >= why.heightForWidth(why.width()), win.tabs.tabText(index)
            assert why.height() > one_line  # its words take two lines here
            bottom = why.mapTo(win, QPoint(0, why.height())).y()
            assert bottom <= win.height()
            assert win.width() <= size[0]
            assert win.height() <= size[1]
        p.shoulder_x.setValue(-12.0)
        p.refresh()
        QApplication.processEvents()
        assert "build" in enabled(win)
        assert why.whole == ""
        assert why.height() == one_line  # back to one line: the bar keeps its place
        win.close()


# -- #16: the simulator's seed -------------------------------------------------------------
@pytest.mark.slow
def test_the_simulators_seed_is_new_each_trial_unless_fixed(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        p = win.parameters_tab
        register_patient(qtbot, win)
        short_trial(win)
        assert not p.robot_choice.fix_seed.isChecked()  # a new one each trial by default
        assert p.backend().seed is None
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=60000)
        click(qtbot, win.robot.buttons["connect"])
        qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)
        assert "a new seed each trial" in win.backend_label.text()
        for _ in range(2):  # two trials at one setting: two seeds
            click(qtbot, win.robot.buttons["start"])
            qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=60000)
            qtbot.waitUntil(lambda: "start" in enabled(win), timeout=60000)
        from app.trials.reader import read_trial

        trials = win.registry.trials_for_patient(win.patient.code)
        qtbot.waitUntil(lambda: all(win.registry.proposal(t.id) is not None
                                    for t in trials), timeout=60000)
        seeds = {read_trial(win.registry.trial_path(t)).backend for t in trials}
        assert len(seeds) == 2, seeds
        assert all("seed " in seed for seed in seeds), seeds
        p.robot_choice.fix_seed.setChecked(True)
        p.robot_choice.seed.setValue(4242)
        assert "start" not in enabled(win)  # the seed is part of what runs: Build first
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: "start" in enabled(win), timeout=60000)
        assert "seed 4242" in win.backend_label.text()
        p.robot_choice.seed.setValue(7)  # a change after Build: Start waits for Build
        assert "start" not in enabled(win)
    finally:
        win.close()


def test_views_of_a_trial_name_it_in_the_therapists_words():
    from ui.views.replay_strip import which_trial
    from ui.views.trialview import TrialView

    view = TrialView()
    view.source = Path("data/trials/P1ZTTAQ/P1ZTTAQ_S012_T004_20261203T101502Z.h5")
    words = which_trial(view)
    assert words.startswith("P1ZTTAQ, session 12, trial 4, 03 Dec 2026")
    view.source = Path("elsewhere.h5")
    assert which_trial(view) == "elsewhere.h5"
