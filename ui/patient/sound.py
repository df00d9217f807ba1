"""The patient's screen's optional tone: a short beep with "Go!" and a higher one on a hit.

Why not Qt: the console installs PySide6-Essentials, which has no QtMultimedia (QSoundEffect
is in PySide6-Addons, a second large wheel of Qt modules the console does not otherwise use),
and QApplication.beep() is the desktop's bell, silent on most Linux desktops. The tone is
instead a WAV file written once (stdlib `wave`: a sine with raised-cosine ramps, so it starts
and ends without a click) and handed to the platform's own player without waiting for it:
`winsound` on Windows (stdlib), `afplay` on macOS, and on Linux the first of `pw-play`
(PipeWire), `paplay` (PulseAudio) and `aplay` (ALSA) on the PATH. Starting a player costs
the GUI thread a process start (about a millisecond), never the sound's length; the loop
runs in its own process and does not see it.

When no player is found, `Tone.available` is False and `why_not` says what to install; the
console's menu shows the option greyed with that line, so a silent tone is never a surprise.
"""

from __future__ import annotations

import math
import shutil
import struct
import subprocess
import sys
import tempfile
import wave
from pathlib import Path

from device.safewrite import write_bytes

RATE_HZ = 22050
GO_HZ = 880.0  # A5: clear to older ears, well inside the range age spares longest
HIT_HZ = 1320.0  # a fifth above: the same family, told apart
TONE_S = 0.25
RAMP_S = 0.01
LINUX_PLAYERS = ("pw-play", "paplay", "aplay")


def tone_wav(frequency_hz: float, duration_s: float = TONE_S, rate_hz: int = RATE_HZ,
             amplitude: float = 0.5) -> bytes:
    """A mono 16-bit WAV of a sine with raised-cosine ramps of RAMP_S at both ends."""
    n = round(duration_s * rate_hz)
    ramp = max(1, round(RAMP_S * rate_hz))
    frames = bytearray()
    for k in range(n):
        edge = min(k, n - 1 - k)
        gain = 0.5 - 0.5 * math.cos(math.pi * edge / ramp) if edge < ramp else 1.0
        value = amplitude * gain * math.sin(2.0 * math.pi * frequency_hz * k / rate_hz)
        frames += struct.pack("<h", round(32767 * value))
    with tempfile.SpooledTemporaryFile() as buffer:
        with wave.open(buffer, "wb") as out:
            out.setnchannels(1)
            out.setsampwidth(2)
            out.setframerate(rate_hz)
            out.writeframes(bytes(frames))
        buffer.seek(0)
        return buffer.read()


def find_player() -> tuple[list[str] | None, str]:
    """The command that plays a WAV file given after it (None on Windows: winsound), and
    "" or why there is none."""
    if sys.platform == "win32":
        return None, ""
    names = ("afplay",) if sys.platform == "darwin" else LINUX_PLAYERS
    for name in names:
        found = shutil.which(name)
        if found:
            return ([found, "-q"] if name == "aplay" else [found]), ""
    return None, ("no sound player found (" + ", ".join(names) + "): install one "
                  "(PipeWire, PulseAudio's pulseaudio-utils or ALSA's alsa-utils) for the tone")


class Tone:
    """The two tones, written to a private temporary folder once, played without waiting."""

    def __init__(self) -> None:
        self.command, self.why_not = find_player()
        self.available = not self.why_not
        self._folder = tempfile.TemporaryDirectory(prefix="rehab-tone-")
        self.files = {}
        for name, hz in (("go", GO_HZ), ("hit", HIT_HZ)):
            # the guarded write (whole, 0600, never over a file) into a private new folder
            self.files[name] = write_bytes(Path(self._folder.name) / f"{name}.wav",
                                           tone_wav(hz))
        self._playing: list[subprocess.Popen] = []
        self.played: list[str] = []

    def play(self, name: str) -> None:
        """Start the tone `name` ("go" or "hit") and return at once."""
        if not self.available:
            return
        self._playing = [p for p in self._playing if p.poll() is None]  # reap the finished
        path = self.files[name]
        if self.command is None:
            import winsound

            winsound.PlaySound(str(path), winsound.SND_FILENAME | winsound.SND_ASYNC)
        else:
            self._playing.append(subprocess.Popen(
                [*self.command, str(path)], stdin=subprocess.DEVNULL,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        self.played.append(name)

    def close(self) -> None:
        for process in self._playing:
            if process.poll() is None:
                process.terminate()
            process.wait(timeout=5)
        self._playing = []
        self._folder.cleanup()
