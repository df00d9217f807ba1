"""The Quanser HIL Python API as the robot's backend (device.hardware.quanser) meets it:
its import, only at Connect (and what to install when it is missing), its error numbers,
and each HILError in words: what failed, on which board, and what to do.
"""

from __future__ import annotations

from typing import Any

from device.errors import BackendError, BackendUnavailable
from device.hardware.settings import HardwareSettings

_INSTALL = (
    "Install the Quanser HIL Python API into this Python environment: on Windows the "
    "quanser_api wheel from the Quanser SDK or QUARC `python` folder "
    "(`pip install <folder>/quanser_api-*.whl`), on Linux the apt package "
    "python3-quanser-apis; both need the Quanser SDK's native libraries."
)

# HIL error numbers (HILError.error_code is their negative).
_BOARD_NOT_FOUND = 108
_BOARD_IN_USE = 109
_BUFFER_OVERFLOW = 111
_INVALID_BOARD_HANDLE = 113
_INVALID_ENCODER_CHANNEL = 124
_INVALID_ANALOG_OUTPUT_CHANNEL = 133
_UNRECOGNIZED_BOARD_TYPE = 179
_INVALID_BOARD_IDENTIFIER = 401
SET_ANALOG_OUTPUT_RANGES_NOT_SUPPORTED = 461
_CARD_OPTION_NOT_RECOGNIZED = 573
_WATCHDOG_NOT_SUPPORTED = range(591, 600)
WATCHDOG_CLEAR_NOT_SUPPORTED = 599
_ANALOG_EXPIRATION_NOT_ZERO = 601
_DIGITAL_EXPIRATION_NOT_TRISTATE = 602
_Q8_EXPIRATIONS_NOT_CONFIGURED = 614


def import_hil() -> Any:
    """`quanser.hardware`, imported now. Its cffi layer loads the native HIL
    libraries at import and raises OSError (not ImportError) without them."""
    try:
        from quanser import hardware
    except (ImportError, OSError) as exc:
        raise BackendUnavailable(
            f"The Quanser HIL Python API cannot be loaded here ({type(exc).__name__}: {exc}). "
            f"{_INSTALL}"
        ) from exc
    return hardware


def watchdog_expired(settings: HardwareSettings) -> BackendError:
    """The card switched the motors off by itself: the loop did not reload its watchdog."""
    ms = settings.quanser.watchdog_timeout_s * 1e3
    return BackendError(
        f"The Q8 watchdog expired: the control loop did not answer within {ms:.0f} ms, so the "
        "card switched the motor outputs off by itself. The robot stays off until it is "
        "connected again; if this recurs, look at the loop's lateness in the log."
    )

def hil_error(settings: HardwareSettings, card: Any, exc: Any, action: str) -> BackendError:
    """A BackendError (or subclass) for a HILError raised while `action` on `card` (None
    while it is not open): what failed, where, what to do."""
    q = settings.quanser
    code = -int(exc.error_code)
    board = f"Quanser {q.board_type} board #{q.board_identifier}"
    source = settings.source
    detail = f"HIL error -{code}{_runtime_text(exc)}"
    if card is not None and action != "opening the card":
        try:
            if card.watchdog_is_expired():
                return watchdog_expired(settings)
        except Exception:  # the card may be gone altogether; report the original error
            pass
    if code == _BOARD_NOT_FOUND:
        return BackendUnavailable(
            f"{board} was not found ({detail}). Check that it is plugged in and powered and "
            "that the operating system lists it (Device Manager), and that [quanser] "
            f"board_type and board_identifier in {source} match it."
        )
    if code == _BOARD_IN_USE:
        return BackendUnavailable(
            f"{board} is in use by another program ({detail}): stop any QUARC model or "
            "other console using it, then connect again."
        )
    if code == _UNRECOGNIZED_BOARD_TYPE:
        return BackendUnavailable(
            f"The HIL driver for board type {q.board_type!r} is not installed ({detail}). "
            f"Install the Quanser driver for this card, or correct [quanser] board_type in "
            f"{source}."
        )
    if code == _INVALID_BOARD_IDENTIFIER:
        return BackendError(
            f"{q.board_identifier!r} is not a valid identifier for {q.board_type} "
            f"({detail}). Correct [quanser] board_identifier in {source}."
        )
    if code == _INVALID_BOARD_HANDLE:
        return BackendError(
            f"{board} stopped answering while {action} ({detail}): it was closed or its USB "
            "cable was pulled. Check the cable, then connect again."
        )
    if code == _INVALID_ENCODER_CHANNEL:
        return BackendError(
            f"{board} has no encoder channel {list(q.encoder_channels)} ({detail}). Correct "
            f"[quanser] encoder_channels in {source}."
        )
    if code == _INVALID_ANALOG_OUTPUT_CHANNEL:
        return BackendError(
            f"{board} has no analog output {list(q.analog_output_channels)} ({detail}). "
            f"Correct [quanser] analog_output_channels in {source}."
        )
    if code == _CARD_OPTION_NOT_RECOGNIZED:
        return BackendError(
            f"{board} does not recognise the card options {q.card_options!r} ({detail}). "
            f"Correct or empty [quanser] card_options in {source}."
        )
    if code in (_ANALOG_EXPIRATION_NOT_ZERO, _DIGITAL_EXPIRATION_NOT_TRISTATE,
                _Q8_EXPIRATIONS_NOT_CONFIGURED) or code in _WATCHDOG_NOT_SUPPORTED:
        return BackendUnavailable(
            f"{board} refused the watchdog configuration while {action} ({detail}). The "
            "robot is not run without its hardware watchdog: check that board_type matches "
            "the card (a Q8-series card is required)."
        )
    if code == _BUFFER_OVERFLOW:
        return BackendError(
            f"{board} reports a buffer overflow while {action} ({detail}): another program "
            "runs a task on the card. Close it and connect again."
        )
    return BackendError(
        f"{board} failed while {action} ({detail}). Connect again; if it recurs, note the "
        "error number for the technician."
    )


def _runtime_text(exc: Any) -> str:
    """The HIL runtime's own message, when the native runtime can give one."""
    try:
        text = exc.get_error_message()
    except Exception:
        return ""
    return f": {text}" if text else ""
