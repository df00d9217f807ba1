"""A Start the window began and could not carry through takes back all it began (issue 28
#4, the window's side of app.trials.registered): the trial registered at Start, when the
video cannot be written or the loop cannot be asked, is withdrawn, not left 'recording'
with no file (the error escaped the click, the row stayed, and Start waited for that
trial's file for good); a video begun for a trial the loop refused stops and goes with
it."""

from __future__ import annotations

import errno
from pathlib import Path

import pytest

from device.errors import RecordingError
from device.loop.states import State
from tests.ui.session import (
    build_and_connect,
    click,
    open_window,
    register_patient,
    short_trial,
)
from ui.tabs.video import VideoTab


class Camera:
    """A camera filming, whose recordings are files beside the trial as the real one's."""

    running = True

    def __init__(self, refuse: bool) -> None:
        self.refuse, self.recording, self.made = refuse, False, []

    def start_recording(self, path) -> Path:
        if self.refuse:
            raise RecordingError(f"cannot write video beside {path}: {path} already exists "
                                 "and is kept: give another name")
        from device.camera.capture import timestamps_path

        self.recording, self.path = True, Path(path)
        for made in (self.path, timestamps_path(path)):
            made.write_bytes(b"filmed")
            self.made.append(made)
        return timestamps_path(path)

    def stop_recording(self):
        from device.camera.capture import Recording, timestamps_path

        self.recording = False
        return Recording(self.path, timestamps_path(self.path), 1, 0.0, 0.0)


@pytest.fixture
def window(qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    yield win
    win.closing_by_signal = True
    win.close()


def _connected(qtbot, win) -> None:
    register_patient(qtbot, win)
    short_trial(win)
    build_and_connect(qtbot, win)


def _no_trial_left(win) -> None:
    assert win.registry.unfinished_trials() == []
    assert win.registry.trials_for_patient(win.patient.code) == []
    assert win.trial_id is None
    folder = win.registry.data_dir.trials_dir / win.patient.code
    assert not folder.exists() or list(folder.iterdir()) == []


@pytest.mark.slow
@pytest.mark.parametrize("failure", ["video", "loop"])
def test_a_start_that_cannot_go_on_takes_its_trial_back(qtbot, window, monkeypatch, failure):
    win = window
    _connected(qtbot, win)
    if failure == "video":
        monkeypatch.setattr(VideoTab, "camera", property(lambda tab: Camera(refuse=True)))
    else:
        def gone(*args, **kwargs):
            raise BrokenPipeError(errno.EPIPE, "Broken pipe")

        monkeypatch.setattr(win.bridge, "start_trial", gone)
    click(qtbot, win.robot.buttons["start"])  # registered on the job thread, then run
    qtbot.waitUntil(lambda: "the trial was not registered" in win.message.text(),
                    timeout=20000)
    (said,) = [line for line in win.messages.history() if "Start refused" in line]
    assert ("Start refused: cannot write video" if failure == "video" else
            "Start refused: Broken pipe") in said
    assert "\n" not in said
    _no_trial_left(win)
    assert win.state == State.CONNECTED
    # nothing left for Start to wait for, once the next numbers are read again
    qtbot.waitUntil(lambda: win.robot.buttons["start"].isEnabled(), timeout=20000)


@pytest.mark.slow
def test_the_video_of_a_start_the_loop_refuses_goes_with_its_trial(qtbot, window,
                                                                      monkeypatch):
    win = window
    _connected(qtbot, win)
    camera = Camera(refuse=False)
    monkeypatch.setattr(VideoTab, "camera", property(lambda tab: camera))
    asked = []
    monkeypatch.setattr(win.bridge, "start_trial", lambda *args: asked.append(args))
    win.start_trial()
    qtbot.waitUntil(lambda: not win.registering(), timeout=20000)
    assert camera.recording
    assert len(asked) == 1
    # the loop's refusal, as its reply brings it
    win._on_reply("start_trial", False, "start refused: the robot is not at rest")
    assert not camera.recording
    qtbot.waitUntil(lambda: "the trial was not registered" in win.message.text(),
                    timeout=20000)
    assert [path for path in camera.made if path.exists()] == []
    _no_trial_left(win)


def test_a_start_the_window_stopped_waiting_for_is_never_run(qtbot, window):
    """Brief hI, on a loaded PC: the loop answered Start after the window's patience (the
    simulator reopened for the next trial's seed, then more than 10 s of a starved CPU),
    the window took the trial back (withdrawn, its number free again), and then the loop
    started it anyway: 'Trial running: session 1, trial 8' over a trial the registry did
    not have, its file recorded beside the next trial 8's. Here the window waits no time
    at all for the Start's answer; the loop must not run the Start it took too late."""
    win = window
    register_patient(qtbot, win)
    short_trial(win, duration_s=1.5)
    build_and_connect(qtbot, win)
    client = win.bridge.client
    request = client.request

    def impatient(command, timeout=None):
        if type(command).__name__ == "Start":
            timeout = 1e-3  # gone before the loop can answer
        return request(command, timeout)

    client.request = impatient
    code = win.patient.code
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: "The refused trial" in (win.messages.last.text
                                                    if win.messages.last else ""),
                    timeout=30000)
    client.request = request
    # Start again, as the therapist does: the loop takes commands in order, so its answer
    # comes after the first Start was carried out or refused
    qtbot.waitUntil(lambda: "start" in {n for n, b in win.robot.buttons.items()
                                        if b.isEnabled()}, timeout=60000)
    click(qtbot, win.robot.buttons["start"])
    # registered on the job thread (ui.window.start): the trial is the window's once the
    # registry answered
    qtbot.waitUntil(lambda: win.trial_id is not None, timeout=30000)
    trial_id = win.trial_id
    qtbot.waitUntil(lambda: win.unsaved_trial == trial_id
                    and win.registry.trial(trial_id).finished, timeout=60000)
    (trial,) = win.registry.trials_for_patient(code)
    files = sorted(win.registry.data_dir.patient_trials_dir(code).glob("*.h5"))
    assert files == [win.registry.trial_path(trial)], (
        "a trial file the registry does not have: the loop ran the Start taken back")


@pytest.mark.slow
def test_start_waits_for_the_numbers_read_again_after_a_trial_is_taken_back(qtbot, window,
                                                                           monkeypatch):
    """Found by the fresh clone's check: a Start pressed the moment the taken-back trial's
    Start turned green again registered trial 2 (the number shown while trial 1 was being
    started), which the registry refused as a gap: the numbers were read again on the job
    thread and Start did not wait for them. Here that read is held until the test lets it
    go: Start waits meanwhile, then registers trial 1."""
    import threading

    win = window
    _connected(qtbot, win)

    def gone(*args, **kwargs):
        raise BrokenPipeError(errno.EPIPE, "Broken pipe")

    monkeypatch.setattr(win.bridge, "start_trial", gone)
    tab = win.registration_tab
    reader = tab.numbers_reader
    release = threading.Event()
    held: list[bool] = []

    def held_reader():
        read = reader()

        def later():
            held.append(True)
            release.wait(30)
            return read()
        return later

    monkeypatch.setattr(tab, "numbers_reader", held_reader)
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: "the trial was not registered" in win.message.text(),
                    timeout=20000)
    qtbot.waitUntil(lambda: held != [], timeout=20000)
    assert not win.robot.buttons["start"].isEnabled()  # the numbers are still being read
    release.set()
    qtbot.waitUntil(lambda: win.robot.buttons["start"].isEnabled(), timeout=20000)
    assert win.registration.trial_number == 1


@pytest.mark.slow
def test_a_start_the_registry_refuses_shows_the_registrys_count_of_the_session(qtbot,
                                                                              window):
    """Brief hT: after a refused Start the Registration tab's "(N trials so far)" was the
    count before it. Here another station registered trial 1 of the patient's first session
    while the tab said "a new session": the registry refuses this Start's trial 1, and the
    tab says the session the registry has, with its one trial, the refusal kept beneath."""
    win = window
    _connected(qtbot, win)
    tab = win.registration_tab
    assert tab.session_note.text() == "a new session"
    code = win.patient.code
    win.registry.begin_trial(code, win.built, backend="simulator", session_number=1,
                             trial_number=1)  # another station's, meanwhile
    click(qtbot, win.robot.buttons["start"])
    qtbot.waitUntil(lambda: any("Start refused" in line for line in win.messages.history()),
                    timeout=20000)
    qtbot.waitUntil(lambda: tab.session_note.text().endswith("(1 trial so far)"),
                    timeout=20000)
    assert tab.session_note.text().startswith("continues the session of")
    assert not tab.trial_problem.isHidden()  # the refusal stays where it was said
    assert tab.trial.value() == 1  # the numbers too: the therapist decides the next

