"""A fake Trigno Control Utility on localhost that follows its TCP protocol
(device/emg/trigno.py; Delsys Trigno SDK user's guide):

* command port: a greeting line on connect, then ASCII commands each ended by two CR LF,
  each answered by one line ended the same way: `OK` for START/STOP, the value for the
  queries it knows (FRAME INTERVAL?, MAX SAMPLES EMG?, SENSOR n PAIRED?), and
  `INVALID COMMAND` for anything else;
* EMG data port: nothing until START; then, every frame interval, `max samples` samples of
  16 little-endian float32 channels (64 bytes each), written in pieces of random sizes so
  the client must reassemble them, until STOP. Channel c of sample k is
  `signal(k)[c]`, so a test knows every value.

Control surface (not in the real TCU): `greeting`, `paired`, `fake_drop_data_after`
(close the data connection after that many samples), `commands` (what was received).
"""

from __future__ import annotations

import random
import socket
import struct
import threading
import time

import numpy as np

TERMINATOR = b"\r\n\r\n"


def default_signal(k: np.ndarray) -> np.ndarray:
    """16 channels: channel c is (c + 1) µV × sin(2π·k/97) + k·1e-9, exact in float32 enough."""
    c = np.arange(16)
    return ((c + 1) * 1e-6 * np.sin(2 * np.pi * k[:, None] / 97.0) + 1e-9 * (k[:, None] % 1000)
            ).astype("<f4")


class FakeTrignoServer:
    def __init__(self, *, frame_interval_s=0.0135, samples_per_frame=26,
                 greeting="Delsys Trigno System Digital Protocol Version 3.6.0",
                 signal=default_signal, data_port=0, command_port=0):
        self.frame_interval_s = frame_interval_s
        self.samples_per_frame = samples_per_frame
        self.greeting = greeting
        self.signal = signal
        self.paired = {1, 2, 3}
        self.commands: list[str] = []
        self.fake_drop_data_after: int | None = None
        self.sent = 0
        self._streaming = threading.Event()
        self._stop = threading.Event()
        self._command_listener = _listen(command_port)
        self._data_listener = _listen(data_port)
        self.command_port = self._command_listener.getsockname()[1]
        self.data_port = self._data_listener.getsockname()[1]
        self._threads = [threading.Thread(target=self._serve_commands, daemon=True),
                         threading.Thread(target=self._serve_data, daemon=True)]

    @property
    def rate_hz(self) -> float:
        return self.samples_per_frame / self.frame_interval_s

    def __enter__(self):
        for t in self._threads:
            t.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        self._streaming.clear()
        for s in (self._command_listener, self._data_listener):
            s.close()
        for t in self._threads:
            t.join(timeout=5)

    def _accept(self, listener):
        while not self._stop.is_set():
            try:
                conn, _ = listener.accept()
                return conn
            except TimeoutError:
                continue
            except OSError:
                return None
        return None

    # ------------------------------------------------------------------ command port
    def _answer(self, command: str) -> str:
        text = command.strip().upper()
        if text == "START":
            self.sent = 0
            self._streaming.set()
            return "OK"
        if text == "STOP":
            self._streaming.clear()
            return "OK"
        if text == "FRAME INTERVAL?":
            return f"{self.frame_interval_s:.6f}"
        if text == "MAX SAMPLES EMG?":
            return str(self.samples_per_frame)
        parts = text.split()
        if len(parts) == 3 and parts[0] == "SENSOR" and parts[2] == "PAIRED?" \
                and parts[1].isdigit():
            return "YES" if int(parts[1]) in self.paired else "NO"
        return "INVALID COMMAND"

    def _serve_commands(self):
        conn = self._accept(self._command_listener)
        if conn is None:
            return
        with conn:
            conn.sendall(self.greeting.encode() + TERMINATOR)
            buffer = b""
            conn.settimeout(0.05)
            while not self._stop.is_set():
                try:
                    chunk = conn.recv(1024)
                except TimeoutError:
                    continue
                except OSError:
                    return
                if not chunk:
                    return
                buffer += chunk
                while TERMINATOR in buffer:
                    line, buffer = buffer.split(TERMINATOR, 1)
                    command = line.decode("ascii")
                    self.commands.append(command)
                    conn.sendall(self._answer(command).encode() + TERMINATOR)

    # ------------------------------------------------------------------ data port
    def _serve_data(self):
        conn = self._accept(self._data_listener)
        if conn is None:
            return
        rng = random.Random(0)
        with conn:
            pending = b""
            due = time.monotonic()
            while not self._stop.is_set():
                if not self._streaming.wait(0.05):
                    due = time.monotonic()
                    continue
                due += self.frame_interval_s
                delay = due - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
                k = np.arange(self.sent, self.sent + self.samples_per_frame)
                if self.fake_drop_data_after is not None and self.sent >= \
                        self.fake_drop_data_after:
                    conn.shutdown(socket.SHUT_RDWR)
                    return
                pending += self.signal(k).tobytes()
                self.sent += self.samples_per_frame
                # TCP gives no message boundaries: write in random pieces
                while pending:
                    cut = min(len(pending), rng.randint(1, 200))
                    try:
                        conn.sendall(pending[:cut])
                    except OSError:
                        return
                    pending = pending[cut:]


def _listen(port: int) -> socket.socket:
    s = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    s.bind(("127.0.0.1", port))
    s.listen(1)
    s.settimeout(0.1)
    return s


def frame(values) -> bytes:
    """One 16-channel sample as the TCU sends it."""
    return struct.pack("<16f", *values)
