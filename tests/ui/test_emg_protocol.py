"""The guided MVC protocol in the window, driven as a therapist would: choose the EMG
source, see its status, record each muscle's MVC (rest, push with a countdown, the MVC
and its quality at once), record a flagged one again; a missing or misconfigured source
is one line. Against the fake Trigno Control Utility (tests/device/fakes)."""

import time

import numpy as np
import pytest

from core.emg.synthetic import THESIS_MUSCLES
from tests.ui.session import click, fake_trigno, open_window, register_patient

fake = fake_trigno()

FULL_SCALE_V = 0.011  # the Trigno's range (app.emg.live.FULL_SCALE_V)


class Muscles:
    """What the fake base station's sensors pick up: a 100 Hz burst-free contraction on
    each channel at `level` V, clipped at the amplifier's range where `level` exceeds it;
    a sample whose time the window's guided protocol gave to rest (`resting`, set by the
    fixture) a relaxed muscle's `rest_level` instead (the push must rise above it,
    core.emg.mvc). A sample's time is the stream's: its first sample's plus k / rate, as
    a sensor samples the muscle when the sample is due. Not the moment the fake's thread
    makes it: a thread the machine stalled through a rest catches up after it, and the
    rest's samples (stamped by k / rate, device.emg.trigno) read as the push's level."""

    def __init__(self, rate_hz: float) -> None:
        self.rate_hz = rate_hz
        self.level = np.full(16, 2e-4)
        self.rest_level = 5e-6
        self.resting = lambda t_s: np.zeros(t_s.shape, dtype=bool)
        self.first_s = None  # monotonic time of sample 0

    def __call__(self, k: np.ndarray) -> np.ndarray:
        if self.first_s is None:
            self.first_s = time.monotonic() - k[0] / self.rate_hz
        rest = self.resting(self.first_s + k / self.rate_hz)
        level = np.where(rest[:, None], self.rest_level, self.level[None, :])
        wave = np.sin(2 * np.pi * 100.0 * k[:, None] / self.rate_hz) * level
        return np.clip(wave, -FULL_SCALE_V, FULL_SCALE_V).astype("<f4")


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch, start_device=False)
    yield win
    win.emg.stop_live()
    win.close()


@pytest.fixture
def server(window):
    with fake.FakeTrignoServer() as s:
        s.signal = Muscles(s.rate_hz)
        s.signal.resting = lambda t_s: resting(window, t_s)
        yield s


def resting(win, t_s: np.ndarray) -> np.ndarray:
    """Which of the monotonic times `t_s` the window's guided MVC gave to rest (the fake
    muscles relax)."""
    guided = win.emg.guided
    if guided is None:
        return np.zeros(t_s.shape, dtype=bool)
    start_s, end_s = guided.rest_span
    return (t_s >= start_s) & (t_s < end_s)


def test_a_stalled_stream_keeps_each_sample_at_its_own_time():
    """The fake's own check: the samples of a rest made after the rest (the thread
    stalled) are still the rest's, as a real sensor's are (a whole check flagged a sound
    MVC 'no effort above rest' when they were made at the push's level)."""
    muscles = Muscles(2000.0)
    muscles.resting = lambda t_s: (t_s >= muscles.first_s + 1.0) & (t_s < muscles.first_s + 2.0)
    muscles(np.arange(0, 26))
    k = np.arange(2000, 4000)  # the rest's samples, made late
    assert np.abs(muscles(k)).max() <= muscles.rest_level
    assert np.abs(muscles(np.arange(4000, 4400))).max() > 0.9 * 2e-4


def connect_trigno(qtbot, win, server) -> None:
    emg = win.emg
    win.tabs.setCurrentWidget(emg)
    emg.source_kind.setCurrentIndex(emg.source_kind.findData("trigno"))
    qtbot.keyClicks(emg.source_edit, "127.0.0.1")
    emg.source_ports = {"command_port": server.command_port, "data_port": server.data_port}
    click(qtbot, emg.connect_button)
    qtbot.waitUntil(lambda: emg.capture is not None, timeout=10000)


def short_protocol(win) -> None:
    win.emg.rest_seconds.setValue(1.2)  # its last 0.8 s the resting level (core.emg.mvc)
    win.emg.push_seconds.setValue(1.5)


def record(qtbot, win, muscle: str) -> str:
    """Press the muscle's button, follow the prompt through rest and push, return the
    result line."""
    emg = win.emg
    seen = set()

    def done() -> bool:
        seen.add(emg.prompt.text().split(":")[1].split()[0] if ":" in emg.prompt.text()
                 else "")
        return emg.record_buttons[muscle].isEnabled()

    click(qtbot, emg.record_buttons[muscle])
    qtbot.waitUntil(done, timeout=20000)
    return emg.mvc_labels[muscle].text(), seen


def test_each_muscle_guided_flagged_then_recorded_again(qtbot, window, server):
    win = window
    register_patient(qtbot, win)
    connect_trigno(qtbot, win, server)
    assert "EMG streaming from trigno:127.0.0.1" in win.message.text()
    short_protocol(win)
    server.signal.level[1] = 0.03  # the triceps' sensor clips at the amplifier's range
    lines = {}
    for muscle in THESIS_MUSCLES:
        lines[muscle], seen = record(qtbot, win, muscle)
        assert {"rest,", "PUSH"} <= seen  # the patient was told to rest, then to push
    assert lines["biceps"].startswith("biceps brachii: MVC")
    assert lines["biceps"].endswith(": ok")
    assert "saturated. Record again." in lines["triceps"]
    assert "amplifier's limit" in win.emg.mvc_labels["triceps"].toolTip()
    assert win.emg.record_buttons["triceps"].text() == "Record again"
    session = win.emg.session
    assert set(session.records) == set(THESIS_MUSCLES)
    # the biceps' MVC is the maximum RMS envelope of its band-passed 100 Hz wave: 2e-4/√2 V
    assert session.records["biceps"].mvc.value_V == pytest.approx(2e-4 / 2 ** 0.5, rel=0.05)
    # record the flagged one again, the gain lowered
    server.signal.level[1] = 3e-4
    again, _ = record(qtbot, win, "triceps")
    assert again.endswith(": ok")
    assert session.records["triceps"].mvc.value_V == pytest.approx(3e-4 / 2 ** 0.5, rel=0.05)
    assert session.records["triceps"].channel == 1


def test_a_push_too_short_is_flagged(qtbot, window, server):
    win = window
    register_patient(qtbot, win)
    connect_trigno(qtbot, win, server)
    win.emg.rest_seconds.setValue(0.0)
    win.emg.push_seconds.setValue(0.6)
    line, _ = record(qtbot, win, "anterior_deltoid")
    assert "too short. Record again." in line
    assert "ask for a 3–5 s maximal effort" in win.emg.mvc_labels["anterior_deltoid"].toolTip()


def test_a_push_no_stronger_than_the_rest_is_flagged(qtbot, window, server):
    """A push of resting noise (the electrode off the skin or on the wrong muscle, a
    patient who did not push) passed as an MVC 'ok', and every trial normalised by it read
    as many times 100 % MVC: the push must rise above the rest (Hodges & Bui's onset
    threshold, core.emg.mvc)."""
    win = window
    register_patient(qtbot, win)
    connect_trigno(qtbot, win, server)
    short_protocol(win)
    server.signal.level[0] = server.signal.rest_level  # the biceps' sensor: rest throughout
    line, _ = record(qtbot, win, "biceps")
    assert "no effort above rest. Record again." in line, line
    assert "check that the electrode is on the muscle" in \
        win.emg.mvc_labels["biceps"].toolTip()
    server.signal.level[0] = 2e-4
    again, _ = record(qtbot, win, "biceps")
    assert again.endswith(": ok"), again


def test_a_flagged_mvc_is_said_in_short_with_what_to_do_and_the_tab_is_whole(
        qtbot, window, server, caplog):
    """At 1366 × 768 with the source streaming (three plots stacked) the envelope's label
    was cut ("EMG envelope (% MV"); a flagged MVC's message line was its row and its whole
    reason, a paragraph set in small type. The line says the flag in short and what to do;
    the reason is the row's tooltip and in the day log."""
    import pyqtgraph as pg

    win = window
    win.resize(1366, 738)
    qtbot.waitExposed(win)
    register_patient(qtbot, win)
    connect_trigno(qtbot, win, server)
    short_protocol(win)
    server.signal.level[0] = server.signal.rest_level  # the biceps' sensor: rest throughout
    with caplog.at_level("WARNING", logger="ui.tabs.emg"):
        record(qtbot, win, "biceps")
    text = win.message.text()
    assert text.startswith("⚠ biceps brachii's MVC: no effort above rest. Check that the "
                           "electrode is on the muscle"), text
    assert text.count("⚠") == 1
    assert "then record again" in text
    assert "median" not in text  # the reason's figures: in the tooltip and the log
    assert "the push's EMG" in win.emg.mvc_labels["biceps"].toolTip()
    assert any("the push's EMG" in r.getMessage() for r in caplog.records)
    # in the window's own size, not squeezed
    assert win.message.font().pointSizeF() >= 0.99 * win.font().pointSizeF()
    qtbot.waitUntil(lambda: win.emg.live_plot.isVisible(), timeout=5000)
    for plot in win.emg.findChildren(pg.PlotWidget):
        if plot.isVisible():
            left = plot.getPlotItem().getAxis("left")
            text_px = left.label.boundingRect().width()  # drawn turned by 90°
            assert text_px <= left.geometry().height() + 1, left.labelText


def test_the_protocol_refuses_without_a_session_or_a_source(qtbot, window):
    win = window
    emg = win.emg
    win.tabs.setCurrentWidget(emg)
    click(qtbot, emg.record_buttons["biceps"])
    assert "Register the patient first" in win.message.text()
    register_patient(qtbot, win)
    win.tabs.setCurrentWidget(emg)
    click(qtbot, emg.record_buttons["biceps"])
    assert "Connect an EMG source first" in win.message.text()
    assert emg.session.records == {}


def test_a_missing_stream_and_a_refused_base_station_are_one_line_each(qtbot, window):
    win = window
    emg = win.emg
    win.tabs.setCurrentWidget(emg)
    emg.source_kind.setCurrentIndex(emg.source_kind.findData("lsl"))
    qtbot.keyClicks(emg.source_edit, "no-such-emg-stream")
    emg.source_ports = {"timeout_s": 0.3}
    click(qtbot, emg.connect_button)
    qtbot.waitUntil(lambda: emg.connect_button.isEnabled(), timeout=10000)
    assert emg.capture is None
    text = win.message.text()
    assert text.startswith("⚠ EMG not connected: no ")
    assert "no-such-emg-stream" in text
    assert "\n" not in text
    # a base station whose Trigno Control Utility is not running
    with fake.FakeTrignoServer() as server:
        port = server.command_port
    emg.source_kind.setCurrentIndex(emg.source_kind.findData("trigno"))
    emg.source_edit.clear()
    qtbot.keyClicks(emg.source_edit, "127.0.0.1")
    emg.source_ports = {"command_port": port, "timeout_s": 0.5}
    click(qtbot, emg.connect_button)
    qtbot.waitUntil(lambda: "connection refused" in win.message.text(), timeout=10000)
    assert "start the Trigno Control Utility" in win.message.text()
    assert emg.live_status.text().startswith("⚠ no Trigno Control Utility")


def test_the_mvcs_belong_to_the_registered_session(qtbot, window, server):
    win = window
    register_patient(qtbot, win)
    connect_trigno(qtbot, win, server)
    short_protocol(win)
    record(qtbot, win, "biceps")
    session = win.emg.session
    code = win.patient.code
    win.emg.set_session(code, session.session)  # the same session registered again
    assert win.emg.session is session
    assert "biceps" in session.records
    # the biceps' electrode moved to another channel: its MVC no longer holds
    win.emg.channel_boxes["biceps"].setValue(5)
    assert "biceps" not in session.records
    assert "its channel changed" in win.emg.mvc_labels["biceps"].text()
    assert session.channels["biceps"] == 4
    record(qtbot, win, "biceps")
    assert session.records["biceps"].channel == 4
    win.emg.set_session(code, session.session + 1)  # the next session starts without MVCs
    assert win.emg.session.records == {}
    assert win.emg.mvc_labels["biceps"].text() == "biceps brachii: no MVC yet"


def test_a_source_that_dies_between_trials_is_one_line_and_leaves_nothing_to_store(
        qtbot, window, server):
    """…and an MVC under way when it dies, or cancelled, records nothing."""
    win = window
    emg = win.emg
    register_patient(qtbot, win)
    connect_trigno(qtbot, win, server)
    emg.rest_seconds.setValue(0.0)
    emg.push_seconds.setValue(10.0)
    click(qtbot, emg.record_buttons["triceps"])
    qtbot.waitUntil(lambda: "PUSH" in emg.prompt.text(), timeout=5000)
    assert not emg.record_buttons["biceps"].isEnabled()  # one MVC at a time
    click(qtbot, emg.cancel_button)
    assert emg.prompt.text() == "triceps brachii: cancelled; nothing recorded."
    click(qtbot, emg.record_buttons["biceps"])
    qtbot.waitUntil(lambda: "PUSH" in emg.prompt.text(), timeout=5000)
    server.fake_drop_data_after = server.sent + 100
    qtbot.waitUntil(lambda: win.emg.capture is None, timeout=20000)
    assert emg.prompt.text() == ("biceps brachii: the EMG source stopped; nothing recorded. "
                                 "Connect it again, then record.")
    assert emg.session.records == {}
    assert emg.record_buttons["biceps"].isEnabled()
    lost = [line for line in win.messages.history() if "closed the EMG data connection" in line]
    assert len(lost) == 1
    assert "check the source, then Connect EMG" in lost[0]
    assert win.emg.lost is None  # no trial was running: the next one must not get old EMG
    assert win.emg.connect_button.text() == "Connect EMG"
