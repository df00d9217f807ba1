"""A trial run in the window while a live EMG source streams (the fake Trigno Control
Utility): when the trial's file closes, its part of the EMG is stored in the file on the
trial's clock, and the source streams on; with the session's MVCs recorded in the window,
the EMG tab shows each muscle in % MVC while the trial runs and the file keeps them; a
source that dies mid-trial is one line and the trial completes. The real loop and
recorder run behind."""

import numpy as np
import pytest

from app.emg.importing import LIVE_MARGIN_S
from app.trials.reader import read_trial
from core.emg.synthetic import THESIS_MUSCLES
from device.errors import RecordingError
from device.loop.states import State
from device.recording.emgfile import read_emg
from tests.ui.session import click, fake_trigno, open_window, register_patient, short_trial
from tests.ui.test_emg_protocol import Muscles, connect_trigno, record, resting, short_protocol
from ui.views.emg import emg_view

pytestmark = pytest.mark.slow

fake = fake_trigno()


def _readable(qtbot, read):
    """`read()` once it gives something: the file may still be recorded, or be read for
    the report at that moment in the window's job thread (HDF5 then refuses to open it)."""
    found = []

    def there() -> bool:
        try:
            value = read()
        except (RecordingError, OSError):
            return False
        found[:] = [value]
        return value is not None

    qtbot.waitUntil(there, timeout=20000)
    return found[0]


def _said(win, words: str) -> bool:
    """Whether the window has said `words` (its history: everything said, in order)."""
    return any(words in line for line in win.messages.history())


def _stored(qtbot, path):
    return _readable(qtbot, lambda: read_emg(path))


def _checked_in_registry(qtbot, win) -> str:
    """The last trial's file is the one its registry records (its checksum), once the
    window's jobs are done; that checksum."""
    registry = win.registry
    trial = registry.trials_for_patient(win.patient.code)[-1]
    qtbot.waitUntil(lambda: registry.verify_trial_file(trial.id) is None, timeout=20000)
    return registry.trial(trial.id).checksum


def _run_trial(qtbot, win, during=None) -> None:
    """Build, connect, start; `during()` while it runs; back to CONNECTED."""
    if win.built is None:
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=120000)  # may compile
        click(qtbot, win.robot.buttons["connect"])
        qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=20000)
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: win.state == State.RUNNING, timeout=10000)
    if during is not None:
        during()
    qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=60000)


def test_live_emg_is_stored_with_the_trial_when_its_file_closes(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    with fake.FakeTrignoServer() as server:
        try:
            register_patient(qtbot, win)
            short_trial(win, duration_s=1.5)
            emg = win.emg
            emg.source_edit.setText("trigno:127.0.0.1")
            emg.source_ports = {"command_port": server.command_port,
                                "data_port": server.data_port}
            click(qtbot, emg.connect_button)
            qtbot.waitUntil(lambda: emg.capture is not None, timeout=10000)
            _run_trial(qtbot, win)
            # said, in the window's history: the event line may already show the next
            # message when the test looks (the report's job ends just after the EMG's)
            qtbot.waitUntil(lambda: _said(win, "EMG stored with the trial"), timeout=60000)
            stored = _stored(qtbot, win.trial_path)
            assert stored.samples.shape[1] == 16
            assert stored.attrs["source"] == "trigno:127.0.0.1"
            duration = 1.5 + 10.0  # at most: exercise, approach, hold
            assert stored.time_s[0] >= -LIVE_MARGIN_S - 0.01
            assert stored.time_s[-1] <= duration + LIVE_MARGIN_S
            # even on the monotonic clock, and on the trial's clock through the ticks'
            # wall times (app.emg.importing): the simulator's time is nominal, so where
            # its ticks were late (a loaded machine) the trial's clock runs slower than
            # the wall's, by the slope of its ticks' (wall_time, time) there
            step = np.diff(stored.time_s)
            assert (step >= 0).all()
            trial = read_trial(win.trial_path)
            wall = np.ravel(trial.channels["wall_time"])
            time_s = np.ravel(trial.channels["time"])
            within = (stored.time_s[:-1] >= time_s[0]) & (stored.time_s[1:] <= time_s[-1])
            k = np.clip(np.searchsorted(time_s, stored.time_s[:-1][within], side="right") - 1,
                        0, len(time_s) - 2)
            slope = np.diff(time_s)[k] / np.diff(wall)[k]
            assert np.median(step[within] / slope) == pytest.approx(0.0135 / 26, rel=1e-3)
            assert emg.capture is not None
            assert emg.capture.running  # streams on
            # the EMG went into the file after the trial's finish recorded its checksum:
            # the registry keeps the file's new one (exports and studies read it)
            _checked_in_registry(qtbot, win)
        finally:
            emg.stop_live()
            win.close()


def test_the_session_mvcs_give_live_and_stored_percent_mvc(qtbot, tmp_path, monkeypatch):
    """MVCs recorded in the window; the deltoid's with too little effort. During the trial
    the EMG tab scrolls each muscle in % MVC; after it, the trial's file has the muscles'
    EMG with the session's MVCs, and the deltoid's is flagged as lower than the trial."""
    win = open_window(qtbot, tmp_path, monkeypatch)
    with fake.FakeTrignoServer() as server:
        server.signal = Muscles(server.rate_hz)
        server.signal.resting = lambda t_s: resting(win, t_s)
        try:
            register_patient(qtbot, win)
            short_trial(win)
            connect_trigno(qtbot, win, server)
            short_protocol(win)
            server.signal.level[2] = 1e-4  # the deltoid pushed at a fraction of its best
            for muscle in THESIS_MUSCLES:
                assert record(qtbot, win, muscle)[0].endswith(": ok")
            # the reach: biceps at 40 % MVC, triceps at 25 %, the deltoid at 400 %
            server.signal.level[:3] = (0.8e-4, 0.5e-4, 4e-4)
            emg = win.emg
            win.tabs.setCurrentWidget(emg)
            live = {}

            def in_percent() -> bool:
                names = [c.name() for c in emg.live_curves]
                if emg.live_unit != "% MVC" or len(names) != 3:
                    return False
                live.update({n: c.getData()[1][-1] for n, c in zip(names, emg.live_curves,
                                                                   strict=True)})
                return True

            def during() -> None:
                qtbot.waitUntil(in_percent, timeout=20000)
                click(qtbot, emg.record_buttons["biceps"])  # an MVC mid-trial: refused
                assert "A trial is running: record the MVCs before" in win.message.text()

            _run_trial(qtbot, win, during)
            assert set(live) == {"biceps brachii", "triceps brachii", "anterior deltoid"}
            assert live["biceps brachii"] == pytest.approx(40, rel=0.1)
            assert live["triceps brachii"] == pytest.approx(25, rel=0.1)
            assert live["anterior deltoid"] == pytest.approx(400, rel=0.1)
            qtbot.waitUntil(lambda: "in % of the session's MVCs" in
                            "\n".join(win.messages.history()), timeout=60000)
            stored = _stored(qtbot, win.trial_path)
            assert stored.muscles == THESIS_MUSCLES
            assert stored.names == ("EMG1", "EMG2", "EMG3")
            assert stored.mvc["anterior_deltoid"]["flags"] == ["below_trial_activity"]
            assert stored.mvc["biceps"]["flags"] == []
            history = "\n".join(win.messages.history())
            assert "anterior deltoid: MVC" in history
            assert "MVC: lower than the trial's activity. Ask for a maximal push, then record " \
                    "again" in history
            assert "lower than the trial's activity" in emg.mvc_labels["anterior_deltoid"].text()
            view = _readable(qtbot, lambda: emg_view(win.trial_path) if
                             not emg_view(win.trial_path).message else None)
            biceps = view.percent[:, view.muscles.index("biceps")]
            assert np.nanmedian(biceps) == pytest.approx(40, rel=0.1)
            _checked_in_registry(qtbot, win)
            # an MVC recorded again after the trial goes into the session's trials so far
            before = win.registry.trials_for_patient(win.patient.code)[-1].checksum
            server.signal.level[:3] = (2e-4, 2e-4, 8e-4)  # pushing, as for an MVC
            record(qtbot, win, "anterior_deltoid")
            qtbot.waitUntil(lambda: _said(win, "The session's MVCs are stored in its"),
                            timeout=60000)
            assert _checked_in_registry(qtbot, win) != before
        finally:
            win.emg.stop_live()
            win.close()


def test_a_stream_that_dies_mid_trial_is_one_line_and_the_trial_completes(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    with fake.FakeTrignoServer() as server:
        try:
            register_patient(qtbot, win)
            short_trial(win)
            connect_trigno(qtbot, win, server)

            def die() -> None:
                server.fake_drop_data_after = server.sent + 200
                qtbot.waitUntil(lambda: win.emg.capture is None, timeout=20000)

            _run_trial(qtbot, win, die)
            qtbot.waitUntil(lambda: "EMG stored with the trial up to where the source stopped"
                            in "\n".join(win.messages.history()), timeout=60000)
            history = win.messages.history()
            lost = [line for line in history if "closed the EMG data connection" in line]
            assert len(lost) == 1
            assert "The trial goes on without EMG" in lost[0]
            assert "⚠" in lost[0]
            trial = _readable(qtbot, lambda: read_trial(win.trial_path))
            assert trial.closed
            assert trial.status == "complete"
            stored = _stored(qtbot, win.trial_path)
            assert stored.samples.shape[0] > 0
        finally:
            win.emg.stop_live()
            win.close()


class MicrovoltsAsVolts:
    """A live LSL source whose amplifier sends µV that it was opened as volts (lsl:amp@V):
    two named channels of about 300 "V", stamped on the monotonic clock as they come."""

    rate_hz = 1000.0
    labels = ("biceps_r", "triceps_r")

    def __init__(self) -> None:
        import time

        self.next_s = time.monotonic()

    def read(self, timeout_s=0.1):
        import time

        time.sleep(min(timeout_s, 0.02))
        n = int((time.monotonic() - self.next_s) * self.rate_hz)
        stamps = self.next_s + np.arange(max(n, 0)) / self.rate_hz
        self.next_s += max(n, 0) / self.rate_hz
        return stamps, 300.0 * np.sin(2 * np.pi * 97.3 * stamps)[:, None] * np.ones((1, 2))

    def close(self) -> None:
        pass


def test_emg_in_the_wrong_unit_is_recorded_with_the_trial_and_its_file_says_so(
        qtbot, tmp_path, monkeypatch):
    """Brief hT: a live stream whose numbers look like µV given as V was warned on the EMG
    tab while the trial stored it without a word: its file held 300 "V" of EMG for any
    reader after. The record is the truth of the trial: it keeps what the source gave,
    and says the problem as its event "emg" at the tick the loop took it, within the
    trial, whatever tab was in view."""
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
        win.emg._opened(None, (MicrovoltsAsVolts(), "lsl:amp"))
        _run_trial(qtbot, win)
        qtbot.waitUntil(lambda: _said(win, "EMG stored with the trial"), timeout=60000)
        assert win.tabs.currentWidget() is not win.emg  # the tab was out of view
        stored = _stored(qtbot, win.trial_path)
        assert stored.names == MicrovoltsAsVolts.labels
        assert np.abs(stored.samples).max() > 250.0  # what came, as it came
        trial = read_trial(win.trial_path)
        (said,) = [e for e in trial.events if e["kind"] == "emg"]
        assert "biceps_r reaches" in said["message"]
        assert "in volts as lsl:amp gives them" in said["message"]
        assert said["values"] == {"source": "lsl:amp"}
        assert 0.0 <= said["time_s"] <= float(np.ravel(trial.channels["time"])[-1])
    finally:
        win.emg.stop_live()
        win.close()
