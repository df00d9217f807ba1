"""The thesis robot's own hardware: a Quanser Q8-series card and the ATI Nano25 (thesis §3.2).

The Q8 reads the two motor encoders and drives the two current amplifiers with
its analog outputs; the handle's force sensor is read through an NI card
(device.hardware.forcesensor). Both vendor APIs are imported only in `open()`, so the
console runs (with the simulator) on machines that have neither.

Per tick
--------
read:   read_encoder (immediate I/O) → watchdog_reload → counts → joint angles
        → force sensor's newest sample
write:  joint torque → motor current τ / (K_T · gear) → × motor sign, clamped to the
        rated current → volts = current / amplifier gain, clamped to the voltage
        limit → write_analog

Timing: immediate I/O, not a hardware-timed encoder task
---------------------------------------------------------
Quanser's examples pace a loop with a hardware-timed encoder task
(`task_read_encoder` blocks until the card's next sample). Our 2 ms loop keeps
its own absolute deadlines (device/loop/realtime.py); a second clock pacing the same
loop would make each tick wait for whichever comes later, and the two clocks
drift apart until the task's buffer overflows (HIL error -111) or the loop
idles. `read_encoder` returns the counts at the moment of the call (one USB
round trip on the Q8-USB), so the loop's timing stays its own, nothing can
overflow, and `time_s` is the monotonic clock just after the counts arrived.

Watchdog
--------
The Q8's watchdog is started last in `open()` with `watchdog_timeout_s`, and
reloaded on every `read()`. If the loop stops reading for longer (a crash, a
hung process, a pause of the OS), the card itself forces every analog output to
0 V and every digital output to tristate, without any software. After an expiry
`watchdog_reload` returns False and the card keeps its outputs off until
`watchdog_clear`; `read()` then raises BackendError, which the supervisor turns
into its latched safe state. Only a new `open()` (Connect) clears it.

Homing
------
The encoders are relative: `open()` zeroes both counters, so the robot must be
in its documented homing pose at Connect; from then on

    θ = homing angle + sign · counts · 2π / counts_per_joint_rev     (core.motor)
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from core.motor import MotorParameters
from core.robot import RobotModel
from device.backend import REAL_TIME, SensorReading
from device.errors import BackendError
from device.hardware.forcesensor import AtiForceSensor
from device.hardware.hil import (
    SET_ANALOG_OUTPUT_RANGES_NOT_SUPPORTED,
    WATCHDOG_CLEAR_NOT_SUPPORTED,
    hil_error,
    import_hil,
    watchdog_expired,
)
from device.hardware.settings import HardwareSettings

log = logging.getLogger(__name__)

Q8_ANALOG_OUTPUTS = 8
Q8_DIGITAL_OUTPUTS = {"q8_usb": 8, "q8": 32}
"""Every analog and digital output of the card gets a watchdog expiration state
(Q8-series boards refuse to start the watchdog otherwise, HIL error -614)."""

ENCODER_MODE_X4 = 4  # EncoderQuadratureMode.X4: 4000 counts/rev from a 1000-line encoder
DIGITAL_TRISTATE = 2  # DigitalState.TRISTATE

class QuanserBackend:
    """The real robot: Q8 card (encoders, amplifiers, watchdog) plus the ATI Nano25.

    `motors` are the two joints' drives (core.motor; default the thesis robot's
    Table 3.1). `force_sensor` defaults to an AtiForceSensor on the settings'
    NI channels. `clock` stamps the readings (monotonic seconds).
    """

    name = "quanser"
    timing = REAL_TIME  # a real robot: the loop's late-tick watchdog guards it

    def __init__(
        self,
        settings: HardwareSettings,
        motors: tuple[MotorParameters, MotorParameters] | None = None,
        *,
        force_sensor: AtiForceSensor | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.settings = settings
        q = settings.quanser
        self.motors = motors if motors is not None else RobotModel().motors
        self.force_sensor = (
            force_sensor if force_sensor is not None else AtiForceSensor(settings.force_sensor)
        )
        self._clock = clock
        self._hil: Any = None
        self._card: Any = None
        self._safe_state_failing = False
        # Buffers in the exact C types the HIL API reinterprets them as.
        self._encoder_channels = np.array(q.encoder_channels, dtype=np.uint32)
        self._output_channels = np.array(q.analog_output_channels, dtype=np.uint32)
        self._counts = np.zeros(2, dtype=np.int32)
        self._volts = np.zeros(2, dtype=np.float64)
        self._zero_volts = np.zeros(2, dtype=np.float64)
        self._rad_per_count = tuple(
            sign * 2.0 * math.pi / motor.counts_per_joint_rev
            for sign, motor in zip(q.encoder_signs, self.motors, strict=True)
        )
        self._home = q.homing_joint_angles_rad
        self._max_current = tuple(m.max_current_A for m in self.motors)
        self._volts_per_Nm = tuple(
            sign / (motor.torque_constant_Nm_per_A * motor.gear_ratio * q.amplifier_gain_A_per_V)
            for sign, motor in zip(q.motor_signs, self.motors, strict=True)
        )
        self._max_volts = tuple(
            min(current / q.amplifier_gain_A_per_V, q.output_voltage_limit_V)
            for current in self._max_current
        )

    # -- state
    @property
    def is_open(self) -> bool:
        return self._card is not None

    @property
    def commanded_volts(self) -> tuple[float, float]:
        """The analog-output volts of the last write (after sign and clamps)."""
        return (float(self._volts[0]), float(self._volts[1]))

    @property
    def tare(self):
        """How the force sensor's zero at the last `open()` went (device.backend.Tare),
        None before one."""
        return self.force_sensor.tare

    @property
    def force_sensor_range_N(self) -> tuple[float, float] | None:
        """The handle sensor's rated (planar, normal) range from its calibration file, once
        opened; the safety supervisor takes its saturation and force ceilings from it."""
        return self.force_sensor.rated_range_N

    def volts_for_torque(self, torque1_Nm: float, torque2_Nm: float) -> tuple[float, float]:
        """Amplifier volts for joint torques: τ/(K_T·gear) × sign, clamped to the rated
        current, ÷ amplifier gain, clamped to the output voltage limit."""
        return (
            _clamp(torque1_Nm * self._volts_per_Nm[0], self._max_volts[0]),
            _clamp(torque2_Nm * self._volts_per_Nm[1], self._max_volts[1]),
        )

    def joint_angles(self, counts1: int, counts2: int) -> tuple[float, float]:
        """Absolute link angles (rad) for encoder counts zeroed at the homing pose."""
        return (
            self._home[0] + counts1 * self._rad_per_count[0],
            self._home[1] + counts2 * self._rad_per_count[1],
        )

    # -- Backend protocol
    def open(self) -> None:
        """Open the card in the safe order, tare the force sensor, start the watchdog.

        The robot must be in its homing pose with nobody touching the handle. On any
        failure everything opened so far is released and BackendError is raised.
        """
        if self._card is not None:
            return
        hil = import_hil()
        q = self.settings.quanser
        self._hil = hil
        card = hil.HIL()
        try:
            step = "opening the card"
            card.open(q.board_type, q.board_identifier)
            self._card = card
            step = "setting the card options"
            if q.card_options:
                card.set_card_specific_options(q.card_options, len(q.card_options) + 1)
            step = "clearing the watchdog"
            self._call_unless_unsupported(card.watchdog_clear, WATCHDOG_CLEAR_NOT_SUPPORTED)
            step = "setting the analog output ranges"
            self._set_output_ranges(card)
            step = "zeroing the analog outputs"
            all_outputs = np.arange(Q8_ANALOG_OUTPUTS, dtype=np.uint32)
            card.write_analog(all_outputs, Q8_ANALOG_OUTPUTS, np.zeros(Q8_ANALOG_OUTPUTS))
            step = "setting the watchdog expiration states"
            card.watchdog_set_analog_expiration_state(
                all_outputs, Q8_ANALOG_OUTPUTS, np.zeros(Q8_ANALOG_OUTPUTS)
            )
            digital = Q8_DIGITAL_OUTPUTS[q.board_type]
            card.watchdog_set_digital_expiration_state(
                np.arange(digital, dtype=np.uint32), digital,
                np.full(digital, DIGITAL_TRISTATE, dtype=np.int32),
            )
            step = "setting the encoders to X4 quadrature"
            card.set_encoder_quadrature_mode(
                self._encoder_channels, 2, np.full(2, ENCODER_MODE_X4, dtype=np.int32)
            )
            step = "zeroing the encoder counts at the homing pose"
            card.set_encoder_counts(self._encoder_channels, 2, np.zeros(2, dtype=np.int32))
        except hil.HILError as exc:
            self._abandon()
            raise hil_error(self.settings, self._card, exc, step) from exc
        except BaseException:
            self._abandon()
            raise
        try:
            self.force_sensor.open()
        except BaseException:
            self._abandon()
            raise
        try:
            card.watchdog_start(q.watchdog_timeout_s)
        except hil.HILError as exc:
            self._abandon()
            raise hil_error(self.settings, self._card, exc, "starting the watchdog") from exc
        except BaseException:
            self._abandon()
            raise
        self._volts[:] = 0.0
        log.info("Quanser %s #%s open; watchdog %.0f ms", q.board_type, q.board_identifier,
                 q.watchdog_timeout_s * 1e3)

    def read(self, now_s: float) -> SensorReading:
        """Encoders and force sensor; reloads the watchdog. Raises BackendError."""
        card = self._card
        if card is None:
            raise BackendError("The Quanser card is not open: connect the robot first.")
        try:
            card.read_encoder(self._encoder_channels, 2, self._counts)
            time_s = self._clock()
            alive = card.watchdog_reload()
        except self._hil.HILError as exc:
            raise hil_error(self.settings, self._card, exc, "reading the encoders") from exc
        if not alive:
            raise watchdog_expired(self.settings)
        q1, q2 = self.joint_angles(int(self._counts[0]), int(self._counts[1]))
        fx, fy, fz = self.force_sensor.read()
        return SensorReading(time_s, q1, q2, fx, fy, fz)

    def write(self, torque1_Nm: float, torque2_Nm: float) -> None:
        """Joint torques → amplifier volts (signed, clamped). Raises BackendError."""
        card = self._card
        if card is None:
            raise BackendError("The Quanser card is not open: connect the robot first.")
        if not (math.isfinite(torque1_Nm) and math.isfinite(torque2_Nm)):
            self.safe_state()
            raise BackendError(
                f"Refused torque command ({torque1_Nm}, {torque2_Nm}) N·m: not finite. The "
                "motors were set to zero; this is a controller fault, report it."
            )
        v1, v2 = self.volts_for_torque(torque1_Nm, torque2_Nm)
        self._volts[0] = v1
        self._volts[1] = v2
        try:
            card.write_analog(self._output_channels, 2, self._volts)
        except self._hil.HILError as exc:
            raise hil_error(self.settings, self._card, exc, "writing the motor commands") from exc

    def safe_state(self) -> None:
        """Zero both motor commands. Never raises (the watchdog backs it up)."""
        self._volts[:] = 0.0
        card = self._card
        if card is None:
            return
        try:
            card.write_analog(self._output_channels, 2, self._zero_volts)
        except Exception as exc:
            # Called on every tick of a fault: say it once, not 500 times a second.
            if not self._safe_state_failing:
                log.warning("safe_state: zeroing the motor outputs failed (%r); the Q8 "
                            "watchdog zeroes them within %.0f ms", exc,
                            self.settings.quanser.watchdog_timeout_s * 1e3)
            self._safe_state_failing = True
        else:
            self._safe_state_failing = False

    def close(self) -> None:
        """Zero the motors, stop the watchdog, release the card and the sensor.

        Every step is attempted even when an earlier one fails; a second call does
        nothing. After a watchdog expiry the outputs are already at 0 V and blocked,
        so the watchdog is stopped and cleared first, then the outputs zeroed, which
        leaves the card ready for the next Connect. Raises BackendError afterwards if
        a step failed.
        """
        card, self._card = self._card, None
        failures: list[tuple[str, BaseException]] = []
        if card is not None:
            outputs = np.arange(Q8_ANALOG_OUTPUTS, dtype=np.uint32)
            zeros = np.zeros(Q8_ANALOG_OUTPUTS)

            def zero() -> None:
                card.write_analog(outputs, Q8_ANALOG_OUTPUTS, zeros)

            try:
                expired = bool(card.watchdog_is_expired())
            except Exception:  # an unplugged card: every step below will say so
                expired = False
            steps: list[tuple[str, Callable[[], object]]] = [
                ("stopping the card's tasks", card.task_stop_all)
            ]
            if expired:
                steps += [
                    ("stopping the watchdog", card.watchdog_stop),
                    ("clearing the expired watchdog", card.watchdog_clear),
                    ("zeroing the analog outputs", zero),
                    ("deleting the card's tasks", card.task_delete_all),
                ]
            else:
                steps += [
                    ("zeroing the analog outputs", zero),
                    ("deleting the card's tasks", card.task_delete_all),
                    ("stopping the watchdog", card.watchdog_stop),
                ]
            steps.append(("closing the card", card.close))
            for what, step in steps:
                try:
                    step()
                except Exception as exc:
                    failures.append((what, exc))
        self._volts[:] = 0.0
        try:
            self.force_sensor.close()
        except Exception as exc:
            failures.append(("closing the force sensor", exc))
        if failures:
            for what, exc in failures:
                log.warning("close: %s failed: %r", what, exc)
            text = "; ".join(f"{what}: {exc}" for what, exc in failures)
            raise BackendError(
                f"Closing the robot hardware was incomplete ({text}). The Q8 watchdog zeroes "
                "the motors when it is not reloaded; switch the amplifiers off before unplugging "
                "anything."
            ) from failures[0][1]
        if card is not None:
            log.info("Quanser card closed")

    # -- helpers
    def _set_output_ranges(self, card: Any) -> None:
        ch = self._output_channels
        try:
            card.set_analog_output_ranges(ch, 2, np.full(2, -10.0), np.full(2, 10.0))
        except self._hil.HILError as exc:
            if -exc.error_code != SET_ANALOG_OUTPUT_RANGES_NOT_SUPPORTED:
                raise
            log.info("This card's analog output ranges are not programmable; they must be "
                     "±10 V (check the board's jumpers).")

    def _call_unless_unsupported(self, call: Callable[[], object], code: int) -> None:
        try:
            call()
        except self._hil.HILError as exc:
            if -exc.error_code != code:
                raise

    def _abandon(self) -> None:
        """Undo a half-done open: outputs to zero, watchdog stopped, card and sensor closed."""
        card, self._card = self._card, None
        if card is not None:
            for step in (
                lambda: card.write_analog(
                    np.arange(Q8_ANALOG_OUTPUTS, dtype=np.uint32), Q8_ANALOG_OUTPUTS,
                    np.zeros(Q8_ANALOG_OUTPUTS),
                ),
                card.watchdog_stop,
                card.close,
            ):
                try:
                    step()
                except Exception as exc:
                    log.warning("releasing the card after a failed connect: %r", exc)
        try:
            self.force_sensor.close()
        except Exception as exc:
            log.warning("releasing the force sensor after a failed connect: %r", exc)


def _clamp(value: float, limit: float) -> float:
    return limit if value > limit else -limit if value < -limit else value
