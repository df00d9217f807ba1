"""A Delsys Trigno base station, live, through the Trigno Control Utility's TCP protocol.

The Trigno Control Utility (TCU), running on the PC the base station is plugged into,
serves (Delsys Trigno SDK user's guide; also implemented by pytrigno and libemg):

* a command port, 50040: on connecting, the TCU sends a greeting line
  (`Delsys Trigno System Digital Protocol Version …`); then each command is ASCII
  ended by two CR LF (`START\\r\\n\\r\\n`) and each reply is one line ended the same
  way (`OK`, `INVALID COMMAND`, or the value asked for). `START` starts streaming,
  `STOP` stops it; queries used here: `FRAME INTERVAL?` (s per frame),
  `MAX SAMPLES EMG?` (EMG samples per channel per frame; their ratio is the EMG
  rate, about 1926 Hz on a Trigno, 2148 Hz on an Avanti), `SENSOR n PAIRED?` (YES/NO).
* an EMG data port, 50041 for the Trigno (legacy), 50043 for the Avanti / Trigno+:
  while started, a stream of samples, each 16 channels (one per sensor slot) of
  little-endian float32 volts, 64 bytes per sample. TCP may cut the stream anywhere,
  so samples are reassembled from a byte buffer.

The data carries no time stamps: each received block is stamped with the monotonic
clock on arrival, and sample k of the stream gets t₀ + k/rate, t₀ the earliest start
consistent with every arrival (a block can arrive late, never early), so the stamps
are as even as the rate and never later than the data really arrived.
"""

from __future__ import annotations

import contextlib
import socket
import time
from collections.abc import Callable

import numpy as np

from device.errors import DeviceError

COMMAND_PORT = 50040
EMG_PORT = {"trigno": 50041, "avanti": 50043}
CHANNELS = 16
SAMPLE_BYTES = CHANNELS * 4
TERMINATOR = b"\r\n\r\n"
GREETING_PREFIX = "Delsys Trigno System"


class TrignoError(DeviceError):
    """The Trigno Control Utility cannot be reached or answered wrongly; one line."""


class TrignoClient:
    """Command and EMG data connections to a Trigno Control Utility."""

    channel_count = CHANNELS  # every read has a column per sensor slot, paired or not

    def __init__(self, host: str = "localhost", *, model: str = "trigno",
                 command_port: int = COMMAND_PORT, data_port: int | None = None,
                 timeout_s: float = 3.0, clock: Callable[[], float] = time.monotonic) -> None:
        if model not in EMG_PORT:
            raise TrignoError(f"unknown Trigno model {model!r}; one of {', '.join(EMG_PORT)}")
        self.host, self.model, self.timeout_s, self.clock = host, model, timeout_s, clock
        self.command_port = command_port
        self.data_port = EMG_PORT[model] if data_port is None else data_port
        self._command: socket.socket | None = None
        self._data: socket.socket | None = None
        self._buffer = bytearray()
        self._received = 0  # samples handed out since START
        self._t0: float | None = None
        self.greeting = ""
        self.rate_hz = 0.0
        self.started = False

    # ------------------------------------------------------------------ connection
    def _connect(self, port: int, what: str) -> socket.socket:
        try:
            return socket.create_connection((self.host, port), timeout=self.timeout_s)
        except ConnectionRefusedError:
            hint = (" (an Avanti or Trigno+ streams EMG on 50043: choose the avanti model)"
                    if port == EMG_PORT["trigno"] else "")
            raise TrignoError(f"no Trigno Control Utility {what} at {self.host}:{port} "
                              f"(connection refused): start the Trigno Control Utility on "
                              f"that PC and check the address{hint}") from None
        except TimeoutError:
            raise TrignoError(f"the Trigno Control Utility at {self.host}:{port} did not "
                              f"answer in {self.timeout_s:g} s: check the address and the "
                              "network") from None
        except OSError as exc:
            raise TrignoError(f"cannot reach {self.host}:{port} for the Trigno {what}: "
                              f"{exc.strerror or exc}") from None

    def open(self) -> TrignoClient:
        """Connect the command port, check the greeting, read the EMG rate, connect the
        EMG data port."""
        self._command = self._connect(self.command_port, "command port")
        self.greeting = self._reply("the greeting")
        if not self.greeting.startswith(GREETING_PREFIX):
            self.close()
            raise TrignoError(f"the server at {self.host}:{self.command_port} is not the Trigno "
                              f"Control Utility (it said {self.greeting[:60]!r})")
        interval = self._number("FRAME INTERVAL?")
        per_frame = self._number("MAX SAMPLES EMG?")
        if not (interval > 0 and per_frame > 0):
            self.close()
            raise TrignoError(f"the Trigno Control Utility reports a frame of {interval:g} s "
                              f"with {per_frame:g} EMG samples: no EMG rate")
        self.rate_hz = per_frame / interval
        try:
            self._data = self._connect(self.data_port, "EMG data port")
        except TrignoError:
            self.close()
            raise
        return self

    def __enter__(self) -> TrignoClient:
        return self.open()

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self.started and self._command is not None:
            with contextlib.suppress(TrignoError):  # closing anyway
                self.command("STOP")
        self.started = False
        for s in (self._data, self._command):
            if s is not None:
                s.close()
        self._data = self._command = None

    # ------------------------------------------------------------------ commands
    def _reply(self, what: str) -> str:
        data = bytearray()
        if self._command is None:
            raise TrignoError("the Trigno client is not open")
        deadline = time.monotonic() + self.timeout_s
        while TERMINATOR not in data:
            self._command.settimeout(max(1e-3, deadline - time.monotonic()))
            try:
                chunk = self._command.recv(1024)
            except TimeoutError:
                raise TrignoError(f"the Trigno Control Utility did not answer {what} in "
                                  f"{self.timeout_s:g} s") from None
            if not chunk:
                raise TrignoError(f"the Trigno Control Utility closed the command connection "
                                  f"while answering {what}")
            data += chunk
        line, _, rest = bytes(data).partition(TERMINATOR)
        if rest:
            # a reply is one line; anything after it belongs to nobody
            raise TrignoError(f"unexpected data after the reply to {what}: {rest[:40]!r}")
        return line.decode("ascii", errors="replace").strip()

    def command(self, text: str) -> str:
        """Send one command, return its reply; INVALID COMMAND is an error."""
        if self._command is None:
            raise TrignoError("the Trigno client is not open")
        try:
            self._command.sendall(text.encode("ascii") + TERMINATOR)
        except OSError as exc:
            raise TrignoError(f"cannot send {text!r} to the Trigno Control Utility: "
                              f"{exc.strerror or exc}") from None
        reply = self._reply(repr(text))
        if reply.upper().startswith("INVALID"):
            raise TrignoError(f"the Trigno Control Utility refused {text!r} ({reply})")
        return reply

    def _number(self, query: str) -> float:
        reply = self.command(query)
        try:
            return float(reply.split()[0])
        except (ValueError, IndexError):
            raise TrignoError(f"the Trigno Control Utility answered {query!r} with {reply!r}, "
                              "not a number") from None

    def paired(self, sensor: int) -> bool:
        """Whether sensor slot `sensor` (1–16) has a paired sensor."""
        if not 1 <= sensor <= CHANNELS:
            raise TrignoError(f"sensor {sensor}: slots are numbered 1 to {CHANNELS}")
        return self.command(f"SENSOR {sensor} PAIRED?").upper().startswith("YES")

    def start(self) -> None:
        reply = self.command("START")
        if reply.upper() != "OK":
            raise TrignoError(f"the Trigno Control Utility answered START with {reply!r}")
        self._buffer.clear()
        self._received, self._t0, self.started = 0, None, True

    def stop(self) -> None:
        self.command("STOP")
        self.started = False

    # ------------------------------------------------------------------ data
    @property
    def origin_s(self) -> float | None:
        """Monotonic time of sample 0 of the stream, the best estimate so far (it only moves
        earlier as blocks arrive); sample k is at origin_s + k/rate_hz."""
        return self._t0

    @property
    def sample_count(self) -> int:
        return self._received

    def read(self, timeout_s: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
        """The whole samples received since the last read: (monotonic stamps (k,), EMG
        (k, 16) in V), stamped with the origin known now (`origin_s`: a later read may
        move it earlier; a recording restamps with the last one). Waits up to
        `timeout_s` for data; returns empty arrays if none came."""
        if self._data is None:
            raise TrignoError("the Trigno client is not open")
        self._data.settimeout(timeout_s)
        try:
            chunk = self._data.recv(1 << 16)
        except TimeoutError:
            chunk = b""
        except OSError as exc:
            raise TrignoError(f"the Trigno EMG data connection failed: {exc.strerror or exc}") \
                from None
        else:
            if not chunk:
                raise TrignoError("the Trigno Control Utility closed the EMG data connection")
        arrived = self.clock()
        self._buffer += chunk
        n = len(self._buffer) // SAMPLE_BYTES
        if n == 0:
            return np.empty(0), np.empty((0, CHANNELS), dtype=np.float32)
        samples = np.frombuffer(bytes(self._buffer[: n * SAMPLE_BYTES]), dtype="<f4")
        del self._buffer[: n * SAMPLE_BYTES]
        first = self._received
        self._received += n
        # the earliest start consistent with this arrival: the last sample came by `arrived`
        start = arrived - (self._received - 1) / self.rate_hz
        self._t0 = start if self._t0 is None else min(self._t0, start)
        stamps = self._t0 + np.arange(first, self._received) / self.rate_hz
        return stamps, samples.reshape(n, CHANNELS)
