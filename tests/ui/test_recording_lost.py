"""A trial whose file the recorder could not finish, in the real window on the simulator:
the device link says "lost" (device.recording.recorder, device.recording.salvage), the
window finishes the trial in the registry with the fault it saw as the cause, Start
waits for no file, and the next trial records whole.

Before, a recorder that could not make or close a trial's file only said "error": the
trial stayed 'recording' in the registry (its cause nowhere), Start waited for a file
that never closed, and the recorder's flag stayed raised, so every later trial faulted
at once."""

from __future__ import annotations

from pathlib import Path

from device.loop.states import State
from tests.ui.session import click, enabled, open_window, register_patient, short_trial


def test_a_trial_whose_file_cannot_be_made_is_finished_with_its_cause_and_the_next_records(
        qtbot, tmp_path, monkeypatch):
    win = open_window(qtbot, tmp_path, monkeypatch)
    try:
        register_patient(qtbot, win)
        short_trial(win, duration_s=1.5)
        start_trial = win.bridge.start_trial
        away: list[tuple[Path, Path]] = []

        def folder_gone(path: str, subject, *shown) -> None:
            # the trial's folder vanishes between its registration and the recorder's
            # create (a data disk unplugged, a folder moved by hand)
            folder = Path(path).parent
            away.append((folder, folder.rename(folder.with_name(folder.name + ".away"))))
            start_trial(path, subject, *shown)

        monkeypatch.setattr(win.bridge, "start_trial", folder_gone)
        click(qtbot, win.robot.buttons["build"])
        qtbot.waitUntil(lambda: win.state == State.BUILT, timeout=20000)
        click(qtbot, win.robot.buttons["connect"])
        qtbot.waitUntil(lambda: win.state == State.CONNECTED, timeout=20000)
        click(qtbot, win.robot.buttons["start"])
        qtbot.waitUntil(lambda: win.unsaved_trial is not None, timeout=30000)
        assert win.trial_id is None  # Start waits for no file
        assert win.state == State.FAULTED
        [lost] = win.registry.trials_for_patient(win.patient.code)
        assert lost.status == "recording_lost"
        # its cause: the fault the window saw, and what happened to the file
        assert lost.end_reason.startswith("The trial file could not be written"), lost
        assert "does not exist" in lost.end_reason, lost
        assert any("Recording problem" in line for line in win.messages.history())
        # and then what the registry keeps of it, in the message line (ui.views.saved)
        assert "Trial 1 of session 1 registered as recording lost" in win.message.text()
        (folder, moved), = away
        moved.rename(folder)  # the disk is back

        monkeypatch.setattr(win.bridge, "start_trial", start_trial)
        click(qtbot, win.clear_button)
        qtbot.waitUntil(lambda: "start" in enabled(win), timeout=20000)
        click(qtbot, win.robot.buttons["start"])
        qtbot.waitUntil(lambda: win.unsaved_trial not in (None, lost.id), timeout=60000)
        trials = win.registry.trials_for_patient(win.patient.code)
        assert sorted(t.status for t in trials) == ["complete", "recording_lost"]
    finally:
        win.close()

