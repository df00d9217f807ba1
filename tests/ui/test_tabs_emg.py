"""The EMG tab: % MVC envelopes over the joint torques for a saved trial, the MVC's quality,
and one line when there is nothing to show."""

import shutil

import pytest

from app.emg.session import Contraction, session_mvc
from app.emg.subjects import Subject, record_trial, write_contractions
from app.trials.reader import read_trial
from tests.trialfiles import edited
from tests.ui.session import fake_trigno
from ui.tabs import TABS, VIEW_TABS, EmgTab
from ui.views.emg import emg_view
from ui.views.trialview import TrialView


@pytest.fixture(scope="module")
def trial_with_emg(tmp_path_factory):
    folder = tmp_path_factory.mktemp("emgtab")
    subject = Subject.drawn(2, bad_mvc={"anterior_deltoid": 0.08})
    synthetic = record_trial(folder / "t.h5", subject, seed=0, engine="python")
    plain = shutil.copy(synthetic.path, folder / "no_mvc.h5")
    contractions = write_contractions(folder, subject, session=1)
    session_mvc([synthetic.path], [Contraction(m, p, ch) for m, (p, ch) in contractions.items()])
    return synthetic.path, plain


def test_the_tab_is_a_view_tab_after_the_torques():
    titles = [t for t, _ in TABS]
    assert titles.index("EMG") == titles.index("Joint torques") + 1
    assert EmgTab in VIEW_TABS


def test_a_saved_trial_shows_envelopes_and_flags_the_bad_mvc(qtbot, trial_with_emg):
    path, _ = trial_with_emg
    tab = EmgTab()
    qtbot.addWidget(tab)
    view = TrialView.from_trial(read_trial(path))
    tab.show_view(view)
    # in words, as the live plot and the status line say them (hA: "anterior_deltoid")
    assert [c.name() for c in tab.curves] == ["biceps brachii", "triceps brachii",
                                              "anterior deltoid"]
    x, _ = tab.curves[2].getData()
    assert len(x) == view.n
    text = tab.status.text()
    assert "anterior deltoid: up to" in text
    assert "lower than the trial's activity" in text
    assert "biceps brachii: up to" in text  # as the key names it
    assert text.count("MVC ok") == 2
    tab.set_cursor(1.0)
    assert tab.cursors[0].isVisible()
    assert tab.cursors[0].value() == pytest.approx(1.0)


def test_nothing_to_show_is_one_line(qtbot, trial_with_emg, tmp_path):
    _, no_mvc = trial_with_emg
    said = emg_view(no_mvc).message
    assert "no MVC for biceps" in said
    # the window's way, not the command line's (found trying the window, brief hT)
    assert "MVC protocol on this tab" in said
    assert "rehab emg mvc" not in said
    assert "No trial file yet" in emg_view(None).message
    bare = shutil.copy(no_mvc, tmp_path / "bare.h5")
    with edited(bare) as f:
        del f["emg"]
    assert "has no EMG" in emg_view(bare).message
    tab = EmgTab()
    qtbot.addWidget(tab)
    live = TrialView.from_trial(read_trial(no_mvc))
    live.finished = False
    tab.show_view(live)
    assert tab.status.text() == "EMG shows here when the trial is saved."
    assert tab.curves == []


def test_a_live_trigno_streams_its_envelopes_and_disconnects(qtbot):
    fake = fake_trigno()
    tab = EmgTab()
    qtbot.addWidget(tab)
    tab.show()  # a hidden tab draws nothing
    with fake.FakeTrignoServer() as server:
        tab.source_edit.setText("trigno:127.0.0.1")
        tab.source_ports = {"command_port": server.command_port,
                            "data_port": server.data_port}
        tab.connect_button.click()
        # generous deadlines: waitUntil returns as soon as it holds, and a loaded 2-core
        # machine (a whole check beside another build) took over 10 s to draw them
        qtbot.waitUntil(lambda: tab.live_status.text().startswith("EMG streaming from "
                                                                  "trigno:127.0.0.1"),
                        timeout=60000)
        # the muscles on channels, named as the tab names them; not the base station's 16
        # channels, most of them empty sensors (they were all drawn until the MVCs)
        qtbot.waitUntil(lambda: len(tab.live_curves) == 3, timeout=60000)
        assert [c.name() for c in tab.live_curves] == [
            "biceps brachii", "triceps brachii", "anterior deltoid"]
        assert "channels 4–16 streaming, not on a muscle: not drawn" in tab.live_key.text()
        x, y = tab.live_curves[2].getData()
        # channel 3 of the fake: 3 µV × a sine, RMS 3/√2 µV
        assert y[-1] == pytest.approx(3 / 2 ** 0.5, rel=0.1)
        assert x[-1] <= 0.0  # seconds before now
        tab.channel_boxes["anterior_deltoid"].setValue(16)  # its sensor is the 16th
        qtbot.waitUntil(lambda: "channels 3–15 streaming" in tab.live_key.text(),
                        timeout=60000)
        qtbot.waitUntil(lambda: tab.live_curves[2].getData()[1][-1] == pytest.approx(
            16 / 2 ** 0.5, rel=0.1), timeout=60000)
        tab.connect_button.click()
        assert tab.capture is None
        assert tab.live_status.text().startswith("Disconnected from trigno:127.0.0.1 after")
        assert tab.connect_button.text() == "Connect EMG"


def test_a_bad_live_source_is_one_line(qtbot):
    tab = EmgTab()
    qtbot.addWidget(tab)
    tab.source_edit.setText("usb:x")
    tab.connect_button.click()
    qtbot.waitUntil(lambda: "give trigno:HOST" in tab.live_status.text(), timeout=10000)
    assert "\n" not in tab.live_status.text()
    assert tab.connect_button.isEnabled()
    assert tab.capture is None


class _QuietSource:
    """An opened LSL source that left a trigger channel out (device.lsl.inlet.notes)."""

    rate_hz, labels = 1000.0, ("biceps",)
    notes = ("left out of the LSL stream named 'amp', not EMG: triggerStream, a trigger channel "
             "of event codes (unit 'code')",)

    def read(self, timeout_s=0.1):
        import time

        import numpy as np

        time.sleep(min(timeout_s, 0.01))
        return np.empty(0), np.empty((0, 1))

    def close(self):
        pass


def test_a_channel_the_source_left_out_is_said_when_it_connects(qtbot):
    tab = EmgTab()
    qtbot.addWidget(tab)
    tab._opened(None, (_QuietSource(), "lsl:amp"))
    text = tab.live_status.text()
    assert text.startswith("EMG streaming from lsl:amp at 1000 Hz.")
    assert "Left out of the LSL stream named 'amp', not EMG: triggerStream" in text
    tab.stop_live()


def test_the_tab_says_once_that_the_live_source_gives_a_wrong_unit(qtbot):
    import types

    import numpy as np

    from ui.views.emg import LiveEmgView

    tab = EmgTab()
    qtbot.addWidget(tab)
    tab.capture = types.SimpleNamespace()  # connected; _show_live draws only then
    said = []
    tab.said.connect(lambda text, problem: said.append((text, problem)))
    problem = "EMG1 reaches 365 V (in volts as lsl:amp@V gives them), more than …"
    view = LiveEmgView(np.zeros(3), np.zeros((3, 1)), ("EMG1",), "µV", problem)
    tab._show_live(None, view)
    tab._show_live(None, view)
    assert said == [(problem, True)]
    assert problem in tab.live_status.text()
    tab.capture = None


def test_the_muscles_channels_are_chosen_by_the_names_the_source_declares(qtbot):
    """Brief hT: the muscle choosers said EMG1, EMG2 … while the LSL stream named its
    channels. Once a source that names them connects, each chooser shows the names, the
    channel chosen kept (a source that names none leaves the numbers)."""
    tab = EmgTab()
    qtbot.addWidget(tab)
    biceps = tab.channel_boxes["biceps"]
    biceps.setValue(3)
    assert biceps.currentText() == "EMG3"

    class Named(_QuietSource):
        labels = ("triceps_r", "deltoid_r", "biceps_r")

    tab._opened(None, (Named(), "lsl:amp"))
    try:
        assert biceps.value() == 3
        assert biceps.currentText() == "biceps_r"
        assert [biceps.itemText(k) for k in range(4)] == [*Named.labels, "EMG4"]
    finally:
        tab.stop_live()


def test_what_the_file_says_of_its_emg_is_shown_with_it(qtbot, trial_with_emg, tmp_path):
    """Found trying the window (brief hT): the trial file keeps what is wrong with its EMG
    (`/emg` notes: the capture ended early, stamps the sender put out of order and that
    were moved), and nothing showed it: the EMG tab looked as for any trial. The tab says
    each note under the envelopes."""
    import json

    synthetic, _ = trial_with_emg
    noted = shutil.copy(synthetic, tmp_path / "noted.h5")
    note = "the capture ended early: the source stopped"
    with edited(noted) as f:
        f["emg"].attrs["notes"] = json.dumps([note])
    assert emg_view(noted).notes == (note,)
    tab = EmgTab()
    qtbot.addWidget(tab)
    tab.show_view(TrialView.from_trial(read_trial(noted)))
    assert f"The EMG: {note}." in tab.status.text()


def test_the_live_key_fits_its_plot_when_the_channels_become_muscles(qtbot):
    """The live plot's key showed the source's 16 channels on one row wider than the plot
    (EMG7, EMG8 off its right), widening the plot past its window; once the MVCs turned
    the channels into three muscles, these were spread over the old width and 'anterior
    deltoid' was cut. The key is in the panel beside the plot, wrapped, every name whole;
    the plot keeps its widget's width."""
    import numpy as np
    from PySide6.QtWidgets import QApplication

    from ui import theme
    from ui.views.emg import LiveEmgView

    theme.apply_theme(QApplication.instance())  # the window's type, as the clinic sees it
    tab = EmgTab()
    qtbot.addWidget(tab)
    tab.resize(1366, 600)
    tab.show()
    qtbot.waitExposed(tab)
    tab.live_plot.show()
    tab.capture = object()  # as if a source streamed: the tab draws what comes
    plot = tab.live_plot
    for names, shown, unit in (
            ([f"EMG{c}" for c in range(1, 17)], [f"EMG{c}" for c in range(1, 17)], "µV"),
            (["biceps", "triceps", "anterior_deltoid"],
             ["biceps brachii", "triceps brachii", "anterior deltoid"], "% MVC")):
        view = LiveEmgView(np.linspace(-1.0, 0.0, 10), np.ones((10, len(names))),
                           tuple(names), unit)
        tab._show_live(None, view)
        for _ in range(5):  # laid out (the key, then the plot round it) and painted
            QApplication.processEvents()
            tab.grab()
        assert plot.getPlotItem().sceneBoundingRect().width() <= plot.width()
        key = tab.live_key
        assert key.isVisible()
        assert key.width() <= key.parentWidget().width()
        for name in shown:
            assert f"&nbsp;{name}" in key.text()
        assert len(tab.live_curves) == len(names)
    assert "EMG16" not in tab.live_key.text()  # the key of what is drawn now
    tab.capture = None


def test_an_mvc_the_tab_flags_is_no_reference_for_the_live_percent(qtbot):
    """The tab's row said the deltoid's MVC was lower than the trial's activity (a trial
    stored after it was recorded, ui.window.trial_emg), yet the live plot read the deltoid
    in % of it, at about 100 %. What the tab says of an MVC (show_mvc) is what the live
    view reads % MVC by: a flagged one is said beside the key until recorded again."""
    import dataclasses

    import numpy as np

    from app.emg.protocol import MvcRecord
    from core.emg.mvc import BELOW_TRIAL, Mvc
    from core.emg.processing import EmgSettings
    from ui.views.emg import live_emg_view

    tab = EmgTab()
    qtbot.addWidget(tab)
    tab.set_session("P1", 1)
    for channel, muscle in enumerate(("biceps", "triceps", "anterior_deltoid")):
        mvc = Mvc(muscle, 1e-4, 1.0, 2.0, 0.0, (), ())
        tab.session.records[muscle] = MvcRecord(mvc, channel, "trigno:x", EmgSettings())
        tab.show_mvc(mvc)
    rate = 2000.0
    t = np.arange(int(2 * rate)) / rate
    x = 1e-4 * np.sin(2 * np.pi * 97.3 * t)[:, None] * np.ones(3)

    def drawn():
        return live_emg_view(t, x, rate, tab.session.copy()).names

    assert drawn() == ("biceps", "triceps", "anterior_deltoid")
    flagged = dataclasses.replace(tab.session.records["anterior_deltoid"].mvc,
                                  flags=(BELOW_TRIAL,), reasons=("lower than the trial",))
    tab.show_mvc(flagged)
    assert "lower than the trial's activity" in tab.mvc_labels["anterior_deltoid"].text()
    assert drawn() == ("biceps", "triceps")
    tab.capture = object()  # as if a source streamed: the tab draws what comes
    tab._show_live(None, live_emg_view(t, x, rate, tab.session.copy()))
    assert "anterior deltoid: not drawn, its MVC is lower than the trial's activity" in \
        tab.live_key.text()
    assert tab.live_unit == "% MVC"
    tab.capture = None
    tab.show_mvc(tab.session.records["anterior_deltoid"].mvc)  # recorded again, ok
    assert drawn() == ("biceps", "triceps", "anterior_deltoid")
