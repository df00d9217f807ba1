"""The patient's screen's optional tone (ui.patient.sound): a clean tone, played by the
platform's player without waiting, once at each Go and on each hit; none without a player,
and the console says why."""

import io
import os
import stat
import sys
import wave

import numpy as np
import pytest

from ui.patient.sound import GO_HZ, TONE_S, Tone, find_player, tone_wav


def test_the_tone_is_a_clean_sine_of_its_pitch_and_length():
    with wave.open(io.BytesIO(tone_wav(GO_HZ))) as read:
        assert (read.getnchannels(), read.getsampwidth()) == (1, 2)
        rate = read.getframerate()
        samples = np.frombuffer(read.readframes(read.getnframes()), "<i2").astype(float)
    assert len(samples) / rate == pytest.approx(TONE_S, abs=1 / rate)
    spectrum = np.abs(np.fft.rfft(samples))
    peak_hz = np.argmax(spectrum) * rate / len(samples)
    assert peak_hz == pytest.approx(GO_HZ, abs=rate / len(samples))
    # no click: it starts and ends at silence
    assert abs(samples[0]) < 50
    assert abs(samples[-1]) < 50
    assert np.abs(samples).max() > 10000


@pytest.mark.skipif(sys.platform != "linux", reason="the Linux players are looked for")
def test_without_a_player_the_tone_is_off_and_says_what_to_install(tmp_path, monkeypatch):
    monkeypatch.setenv("PATH", str(tmp_path))
    command, why_not = find_player()
    assert command is None
    assert why_not.startswith("no sound player found (pw-play, paplay, aplay): install")
    tone = Tone()
    assert not tone.available
    tone.play("go")
    assert tone.played == []
    tone.close()


@pytest.mark.skipif(sys.platform != "linux", reason="a shell script stands for the player")
def test_a_player_on_the_path_is_given_the_tone_file(tmp_path, monkeypatch):
    log = tmp_path / "played.txt"
    player = tmp_path / "paplay"
    player.write_text(f"#!/bin/sh\necho \"$@\" >> {log}\n")
    player.chmod(player.stat().st_mode | stat.S_IEXEC)
    monkeypatch.setenv("PATH", str(tmp_path) + os.pathsep + "/usr/bin:/bin")
    tone = Tone()
    assert tone.available
    tone.play("go")
    tone.play("hit")
    for process in tone._playing:
        process.wait(timeout=30)
    # two players run at once: either may write first
    assert sorted(log.read_text().split()) == sorted([str(tone.files["go"]),
                                                       str(tone.files["hit"])])
    tone.close()
    assert not tone.files["go"].exists()  # its folder goes with it


class _HeardTone:
    def __init__(self) -> None:
        self.played = []

    def play(self, name: str) -> None:
        self.played.append(name)

    def close(self) -> None:
        pass


def test_the_screen_plays_go_once_and_each_hit_once_live_never_in_replay(qtbot, tmp_path):
    from app.trials.headless import simulate_to_file
    from app.trials.reader import read_trial
    from core.games import game_layout, score_game
    from core.trial import THESIS_SUBJECT
    from ui.patient.window import PatientWindow
    from ui.views.patient_screen import PatientOptions
    from ui.views.trialview import TrialView

    params = THESIS_SUBJECT.replace(shape="targets", game="reach", centre_m=(-0.2, 0.35),
                                    radius_m=0.08, n_targets=4, duration_s=6.0,
                                    repetitions=1, time_allowed_s=1.0, assist="as-needed")
    simulate_to_file(params, tmp_path / "t.h5", patient="healthy", seed=1)
    data = read_trial(tmp_path / "t.h5")
    window = PatientWindow(PatientOptions(sound=True))
    qtbot.addWidget(window)
    window.tone = heard = _HeardTone()
    view = TrialView(data.parameters)
    records = data.channels
    for end in range(17, data.n_samples + 17, 17):
        view.append(_rows(records, end - 17, min(end, data.n_samples)))
        window.show_view(view)
    hits = score_game(game_layout(params), data.time, records["position"][:, 0],
                      records["position"][:, 1], records["phase"]).hits
    assert hits >= 1
    assert heard.played == ["go"] + ["hit"] * hits
    replay = TrialView.from_trial(data)
    for t in np.linspace(0.0, float(data.time[-1]), 40):
        replay.cursor = float(t)
        window.show_view(replay)
    assert heard.played == ["go"] + ["hit"] * hits  # the slider makes no sound
    window.set_options(PatientOptions(sound=False))
    window.show_view(TrialView(data.parameters))
    assert len(heard.played) == 1 + hits


def _rows(channels, a, b):
    from device.recording.record import RECORD_DTYPE
    from ui.views.trialview import VIEW_CHANNELS

    rows = np.zeros(b - a, dtype=[(c, RECORD_DTYPE.fields[c][0]) for c in VIEW_CHANNELS])
    for name in VIEW_CHANNELS:
        rows[name] = channels[name][a:b]
    return rows

