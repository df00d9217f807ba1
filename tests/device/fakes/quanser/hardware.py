"""Fake of `quanser.hardware` (Quanser HIL Python API) with a simulated Q8-series board.

Same names, signatures and return conventions as the real cffi wrapper, and its
buffer rules (docs/hardware.md, Testing without the hardware):

* channel, count, volt and enum arrays go to C through `ffi.from_buffer`: any
  buffer-protocol object is accepted, a `list` raises TypeError, a non-contiguous
  array raises ValueError, and the dtype is **not** checked — the bytes are
  reinterpreted as the C type, so an int64 channel array [0, 1] reaches the
  board as channels [0, 0]. A backend passing the wrong dtype therefore reads or
  writes the wrong channels, as it would on the real card;
* output buffers are filled in place and the methods return None;
* errors raise HILError with a negative `error_code`.

The simulated board implements the Q8 watchdog: expiration states must be 0 V on
every analog output and tristate on every digital output before `watchdog_start`
(else -614); once the timeout passes without `watchdog_reload`, the outputs go
to their expiration states, `watchdog_reload` returns False and hardware access
stays blocked until `watchdog_clear`. Which error a blocked access raises on the
real card is not known (docs/hardware.md lists it as unverified), so a board can be
set to raise `FAKE_BLOCKED_ACCESS_CODE` (default) or to ignore blocked writes.

The control surface for tests (`fake_*`, `FakeBoard`) is not part of the real API.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

from quanser.common import GenericError

# Positive QERR numbers (the C API returns their negatives).
QERR_BOARD_NOT_FOUND = 108
QERR_BOARD_IN_USE = 109
QERR_BUFFER_OVERFLOW = 111
QERR_INVALID_BOARD_HANDLE = 113
QERR_INVALID_ENCODER_INPUT_CHANNEL = 124
QERR_INVALID_ANALOG_OUTPUT_CHANNEL = 133
QERR_INVALID_DIGITAL_OUTPUT_CHANNEL = 139
QERR_UNRECOGNIZED_BOARD_TYPE = 179
QERR_INVALID_ANALOG_OUTPUT_RANGE = 398
QERR_INVALID_BOARD_IDENTIFIER = 401
QERR_HIL_SET_ANALOG_OUTPUT_RANGES_NOT_SUPPORTED = 461
QERR_CARD_SPECIFIC_OPTION_NOT_RECOGNIZED = 573
QERR_HIL_WATCHDOG_CLEAR = 599
QERR_ANALOG_EXPIRATION_STATE_NOT_ZERO = 601
QERR_DIGITAL_EXPIRATION_STATE_NOT_TRISTATE = 602
QERR_Q8_SERIES_EXPIRATIONS_NOT_CONFIGURED = 614

FAKE_BLOCKED_ACCESS_CODE = -QERR_INVALID_BOARD_HANDLE
"""What this fake raises for I/O while the watchdog has expired. The real code is
unverified; backends must not depend on it (they ask `watchdog_is_expired`)."""

_ERROR_TEXT = {
    QERR_BOARD_NOT_FOUND: "The board could not be found.",
    QERR_BOARD_IN_USE: "The board is in use by another process.",
    QERR_BUFFER_OVERFLOW: "The buffer has overflowed.",
    QERR_INVALID_BOARD_HANDLE: "An invalid board handle was passed.",
    QERR_INVALID_ENCODER_INPUT_CHANNEL: "An encoder input channel is not valid.",
    QERR_INVALID_ANALOG_OUTPUT_CHANNEL: "An analog output channel is not valid.",
    QERR_INVALID_DIGITAL_OUTPUT_CHANNEL: "A digital output channel is not valid.",
    QERR_UNRECOGNIZED_BOARD_TYPE: "The specified board type is not recognized.",
    QERR_INVALID_ANALOG_OUTPUT_RANGE: "An analog output range is not valid.",
    QERR_INVALID_BOARD_IDENTIFIER: "The board identifier is not valid.",
    QERR_HIL_SET_ANALOG_OUTPUT_RANGES_NOT_SUPPORTED: "hil_set_analog_output_ranges unsupported.",
    QERR_CARD_SPECIFIC_OPTION_NOT_RECOGNIZED: "The card specific option is not recognized.",
    QERR_HIL_WATCHDOG_CLEAR: "hil_watchdog_clear is not supported by this card.",
    QERR_ANALOG_EXPIRATION_STATE_NOT_ZERO: "Analog expiration states must be 0 V.",
    QERR_DIGITAL_EXPIRATION_STATE_NOT_TRISTATE: "Digital expiration states must be tristate.",
    QERR_Q8_SERIES_EXPIRATIONS_NOT_CONFIGURED: "Q8-series: every AO and DO needs a state.",
}

_BOARD_TYPES = ("q8_usb", "q8", "q2_usb", "qpid_e")
_CARD_OPTIONS = {"update_rate", "decimation", "ext_int_polarity", "convert_polarity",
                 "ext_int_watchdog", "use_ext_int", "enc0_dir", "enc0_filter"}


def fake_error_text(error_code: int) -> str:
    return _ERROR_TEXT.get(-error_code, f"Quanser error {error_code}.")


class HILError(GenericError):
    """A HIL call failed; `error_code` is negative (-QERR_xxx)."""


class Clock:
    __slots__ = ()
    SYSTEM_CLOCK_4 = -4
    SYSTEM_CLOCK_3 = -3
    SYSTEM_CLOCK_2 = -2
    SYSTEM_CLOCK_1 = -1
    HARDWARE_CLOCK_0 = 0
    HARDWARE_CLOCK_1 = 1
    HARDWARE_CLOCK_2 = 2


class DigitalState:
    LOW = 0
    HIGH = 1
    TRISTATE = 2
    NO_CHANGE = 3


class EncoderQuadratureMode:
    __slots__ = ()
    NONE = 0
    X1 = 1
    X2 = 2
    X4 = 4


# -- the simulated board --------------------------------------------------------------------------


class FakeBoard:
    """One simulated Q8-series card: its outputs, counters, watchdog and a record of calls.

    `encoder_position` is the physical counter input (what the encoder has turned,
    in counts since power-up); `set_encoder_counts` sets the offset the card reads
    relative to. `plant_counts_per_V_s[ch]` makes analog output ch drive encoder ch
    (a motor at constant speed per volt) when `advance(dt)` is called.
    """

    def __init__(
        self,
        board_type: str,
        identifier: str,
        *,
        analog_outputs: int = 8,
        digital_outputs: int | None = None,
        encoders: int = 8,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.board_type = board_type
        self.identifier = identifier
        self.clock = clock
        self.analog_outputs = analog_outputs
        self.digital_outputs = (8 if board_type == "q8_usb" else 32) if digital_outputs is None \
            else digital_outputs
        self.encoders = encoders
        self.ao_volts = np.zeros(analog_outputs)
        self.ao_ranges = [(-10.0, 10.0)] * analog_outputs
        self.ao_range_programmable = True
        self.encoder_position = np.zeros(encoders, dtype=np.int64)
        self._count_offset = np.zeros(encoders, dtype=np.int64)
        self.quadrature = np.zeros(encoders, dtype=np.int32)
        self.analog_expiration: dict[int, float] = {}
        self.digital_expiration: dict[int, int] = {}
        self.watchdog_supported = True
        self.watchdog_running = False
        self.watchdog_timeout_s = 0.0
        self._watchdog_deadline = 0.0
        self.watchdog_expired = False
        self.blocked_access = "error"  # or "ignore": blocked writes silently dropped
        self.in_use_elsewhere = False
        self.open_handles = 0
        self.card_options = ""
        self.plant_counts_per_V_s = np.zeros(min(analog_outputs, encoders))
        self.calls: list[tuple[str, tuple]] = []
        self.fail: dict[str, int] = {}
        """Method name -> positive QERR code that every call of that method raises."""
        self.broken: Exception | None = None
        """When set, every call raises this (a USB cable pulled mid-session)."""

    # -- what the tests look at
    def counts(self, channel: int) -> int:
        return int(self.encoder_position[channel] - self._count_offset[channel])

    def call_names(self) -> list[str]:
        return [name for name, _ in self.calls]

    def advance(self, dt_s: float) -> None:
        """Let the simulated motors turn for dt_s at the commanded volts."""
        n = len(self.plant_counts_per_V_s)
        self.encoder_position[:n] += np.round(
            self.plant_counts_per_V_s * self.ao_volts[:n] * dt_s
        ).astype(np.int64)

    # -- used by HIL
    def _enter(self, name: str, args: tuple, *, io: bool) -> None:
        self.calls.append((name, args))
        if self.broken is not None:
            raise self.broken
        code = self.fail.get(name)
        if code is not None:
            raise HILError(-code)
        self._update_watchdog()
        if io and self.watchdog_expired and self.blocked_access == "error":
            raise HILError(FAKE_BLOCKED_ACCESS_CODE)

    def _update_watchdog(self) -> None:
        if self.watchdog_running and not self.watchdog_expired \
                and self.clock() > self._watchdog_deadline:
            self.watchdog_expired = True
            for channel, volts in self.analog_expiration.items():
                self.ao_volts[channel] = volts


_BOARDS: dict[tuple[str, str], FakeBoard] = {}


def fake_reset() -> None:
    """Remove every simulated board."""
    _BOARDS.clear()


def fake_install_board(board_type: str = "q8_usb", identifier: str = "0", **kwargs) -> FakeBoard:
    """Plug a simulated board in; `HIL.open(board_type, identifier)` will find it."""
    board = FakeBoard(board_type, identifier, **kwargs)
    _BOARDS[(board_type, identifier)] = board
    return board


def _c_array(buffer, dtype, count: int, *, writable: bool = False) -> np.ndarray:
    """What `ffi.from_buffer(ctype[], buffer)` hands to C: the raw bytes as `dtype`."""
    if isinstance(buffer, list | tuple):
        raise TypeError(
            f"from_buffer() cannot return the address of the raw string within a "
            f"{type(buffer).__name__} object"
        )
    view = memoryview(buffer)
    if not view.c_contiguous:
        raise ValueError("from_buffer() only supports C-contiguous buffers")
    if writable and view.readonly:
        raise ValueError("the buffer is read-only but C writes into it")
    raw = np.frombuffer(view.cast("B"), dtype=dtype)
    if raw.size < count:
        raise ValueError(
            f"buffer holds {raw.size} {np.dtype(dtype).name} values but {count} were passed to C"
        )
    return raw[:count]


class HIL:
    """A handle on one HIL board, as `quanser.hardware.HIL`."""

    INFINITE = 0x7FFFFFFF

    def __init__(self, card_type=None, card_identifier=None) -> None:
        self._card: FakeBoard | None = None
        if card_type is not None or card_identifier is not None:
            self.open(card_type, card_identifier)

    # -- configuration
    def open(self, card_type, card_identifier="0") -> None:
        self.close()
        if card_type not in _BOARD_TYPES:
            raise HILError(-QERR_UNRECOGNIZED_BOARD_TYPE)
        if not isinstance(card_identifier, str) or not card_identifier.isdigit():
            raise HILError(-QERR_INVALID_BOARD_IDENTIFIER)
        board = _BOARDS.get((card_type, card_identifier))
        if board is None:
            raise HILError(-QERR_BOARD_NOT_FOUND)
        board.calls.append(("open", (card_type, card_identifier)))
        if board.in_use_elsewhere:
            raise HILError(-QERR_BOARD_IN_USE)
        board.open_handles += 1
        self._card = board

    def close(self) -> None:
        board = self._card
        if board is None:
            return
        board.calls.append(("close", ()))
        if board.broken is not None:
            self._card = None
            board.open_handles -= 1
            raise board.broken
        board.open_handles -= 1
        self._card = None

    @staticmethod
    def close_all() -> None:
        for board in _BOARDS.values():
            board.open_handles = 0

    @staticmethod
    def get_version():
        return (2024, 1, 0, 0)

    def is_valid(self) -> bool:
        return self._card is not None

    def _board(self) -> FakeBoard:
        if self._card is None:
            raise HILError(-QERR_INVALID_BOARD_HANDLE)
        return self._card

    def set_card_specific_options(self, options, size) -> None:
        board = self._board()
        board._enter("set_card_specific_options", (options, size), io=False)
        if not isinstance(options, str) or not isinstance(size, int) or size < len(options):
            raise TypeError("options must be a str and size an int of at least its length")
        for item in filter(None, options.split(";")):
            if item.split("=")[0] not in _CARD_OPTIONS:
                raise HILError(-QERR_CARD_SPECIFIC_OPTION_NOT_RECOGNIZED)
        board.card_options = options

    def set_analog_output_ranges(self, channels, num_channels, minima, maxima) -> None:
        board = self._board()
        ch = _c_array(channels, np.uint32, num_channels)
        lo = _c_array(minima, np.float64, num_channels)
        hi = _c_array(maxima, np.float64, num_channels)
        board._enter("set_analog_output_ranges", (ch.tolist(), lo.tolist(), hi.tolist()),
                     io=False)
        if not board.ao_range_programmable:
            raise HILError(-QERR_HIL_SET_ANALOG_OUTPUT_RANGES_NOT_SUPPORTED)
        self._check(ch, board.analog_outputs, QERR_INVALID_ANALOG_OUTPUT_CHANNEL)
        for c, a, b in zip(ch, lo, hi, strict=True):
            if (a, b) not in ((-10.0, 10.0), (-5.0, 5.0), (0.0, 10.0), (0.0, 5.0)):
                raise HILError(-QERR_INVALID_ANALOG_OUTPUT_RANGE)
            board.ao_ranges[int(c)] = (float(a), float(b))

    def set_encoder_quadrature_mode(self, channels, num_channels, modes) -> None:
        board = self._board()
        ch = _c_array(channels, np.uint32, num_channels)
        md = _c_array(modes, np.int32, num_channels)
        board._enter("set_encoder_quadrature_mode", (ch.tolist(), md.tolist()), io=False)
        self._check(ch, board.encoders, QERR_INVALID_ENCODER_INPUT_CHANNEL)
        board.quadrature[ch] = md

    def set_encoder_counts(self, channels, num_channels, counts) -> None:
        board = self._board()
        ch = _c_array(channels, np.uint32, num_channels)
        ct = _c_array(counts, np.int32, num_channels)
        board._enter("set_encoder_counts", (ch.tolist(), ct.tolist()), io=True)
        self._check(ch, board.encoders, QERR_INVALID_ENCODER_INPUT_CHANNEL)
        for c, value in zip(ch, ct, strict=True):
            board._count_offset[c] = board.encoder_position[c] - int(value)

    # -- immediate I/O
    def read_encoder(self, channels, num_channels, buffer) -> None:
        board = self._board()
        ch = _c_array(channels, np.uint32, num_channels)
        out = _c_array(buffer, np.int32, num_channels, writable=True)
        board._enter("read_encoder", (ch.tolist(),), io=True)
        self._check(ch, board.encoders, QERR_INVALID_ENCODER_INPUT_CHANNEL)
        out[:] = [board.counts(int(c)) for c in ch]

    def write_analog(self, channels, num_channels, buffer) -> None:
        board = self._board()
        ch = _c_array(channels, np.uint32, num_channels)
        volts = _c_array(buffer, np.float64, num_channels)
        board._enter("write_analog", (ch.tolist(), volts.tolist()), io=True)
        self._check(ch, board.analog_outputs, QERR_INVALID_ANALOG_OUTPUT_CHANNEL)
        if board.watchdog_expired:
            return  # blocked_access == "ignore": the outputs keep their expiration states
        for c, v in zip(ch, volts, strict=True):
            lo, hi = board.ao_ranges[int(c)]
            board.ao_volts[int(c)] = min(max(float(v), lo), hi)

    # -- tasks (this backend uses none; close() stops any left by others)
    def task_stop_all(self) -> None:
        self._board()._enter("task_stop_all", (), io=False)

    def task_delete_all(self) -> None:
        self._board()._enter("task_delete_all", (), io=False)

    # -- watchdog
    def watchdog_set_analog_expiration_state(self, channels, num_channels, voltages) -> None:
        board = self._board()
        ch = _c_array(channels, np.uint32, num_channels)
        volts = _c_array(voltages, np.float64, num_channels)
        board._enter("watchdog_set_analog_expiration_state", (ch.tolist(), volts.tolist()),
                     io=False)
        self._check(ch, board.analog_outputs, QERR_INVALID_ANALOG_OUTPUT_CHANNEL)
        if np.any(volts != 0.0):
            raise HILError(-QERR_ANALOG_EXPIRATION_STATE_NOT_ZERO)
        board.analog_expiration.update({int(c): 0.0 for c in ch})

    def watchdog_set_digital_expiration_state(self, channels, num_channels, states) -> None:
        board = self._board()
        ch = _c_array(channels, np.uint32, num_channels)
        st = _c_array(states, np.int32, num_channels)
        board._enter("watchdog_set_digital_expiration_state", (ch.tolist(), st.tolist()),
                     io=False)
        self._check(ch, board.digital_outputs, QERR_INVALID_DIGITAL_OUTPUT_CHANNEL)
        if np.any(st != DigitalState.TRISTATE):
            raise HILError(-QERR_DIGITAL_EXPIRATION_STATE_NOT_TRISTATE)
        board.digital_expiration.update({int(c): DigitalState.TRISTATE for c in ch})

    def watchdog_start(self, timeout) -> None:
        board = self._board()
        board._enter("watchdog_start", (timeout,), io=False)
        if len(board.analog_expiration) < board.analog_outputs or \
                len(board.digital_expiration) < board.digital_outputs:
            raise HILError(-QERR_Q8_SERIES_EXPIRATIONS_NOT_CONFIGURED)
        board.watchdog_running = True
        board.watchdog_timeout_s = float(timeout)
        board._watchdog_deadline = board.clock() + float(timeout)

    def watchdog_reload(self) -> bool:
        board = self._board()
        board._enter("watchdog_reload", (), io=False)
        if board.watchdog_expired:
            return False
        board._watchdog_deadline = board.clock() + board.watchdog_timeout_s
        return True

    def watchdog_is_expired(self) -> bool:
        board = self._board()
        board._enter("watchdog_is_expired", (), io=False)
        return board.watchdog_expired

    def watchdog_clear(self) -> None:
        board = self._board()
        board._enter("watchdog_clear", (), io=False)
        if not board.watchdog_supported:
            raise HILError(-QERR_HIL_WATCHDOG_CLEAR)
        board.watchdog_expired = False
        board.watchdog_running = False

    def watchdog_stop(self) -> None:
        board = self._board()
        board._enter("watchdog_stop", (), io=False)
        board.watchdog_running = False  # an expiry stays until watchdog_clear

    @staticmethod
    def _check(channels: np.ndarray, count: int, code: int) -> None:
        if np.any(channels >= count):
            raise HILError(-code)
