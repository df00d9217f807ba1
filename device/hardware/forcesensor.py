"""The handle's ATI Nano25 force/torque sensor, read through an NI card with `nidaqmx`.

Six strain-gauge voltages G0..G5 (differential, ±10 V) go to six analog inputs
in order; the ATI calibration matrix turns them into forces and torques
(device.hardware.atical):

    ft = M · (v − v_bias)        v_bias: the unloaded gauges, averaged at connect (tare)

Timing: continuous acquisition, newest sample on demand
-------------------------------------------------------
Of the three ways NI-DAQmx offers to get a low-latency sample (a: on demand, b: the
newest sample of a continuous buffer, c: hardware-timed single point; docs/hardware.md,
Timing), we use (b): the card samples continuously on its own clock
(`sample_rate_Hz`, 2 kHz by default) into a circular buffer that may overwrite
unread samples, and every read asks for the most recent one
(`relative_to = MOST_RECENT_SAMPLE`, `offset = -1`). Why:

* the 2 ms loop owns the timing (device/loop/realtime.py); a read that returns the
  newest sample at once never waits for a clock, so it cannot shift the loop;
  HW_TIMED_SINGLE_POINT (c) would pace the loop by the card's clock instead, and
  only some cards support it;
* the sample is at most one sample period old (0.5 ms at 2 kHz), where an
  on-demand read (a) starts a software-timed conversion on every call and costs
  a full driver round trip each tick;
* overwriting means a late loop never gets "samples no longer available"
  errors, and the tare can simply average the first `tare_samples` samples.

A card that stops acquiring would keep returning its last sample; so each read
also checks `total_samp_per_chan_acquired` and raises BackendTimeout when it has
not advanced for `read_timeout_s`.

Tare: the robot must be at rest with nobody touching the handle when `open()` is
called (the console asks for this at Connect); the first `tare_samples` samples
are averaged into v_bias. A saturated gauge during the tare is refused, and so is a
zero taken under load: a hand on the handle moves the force by more than the sensor's
noise during the tare (`tare_spread_limit_N`, RMS in the plane about its mean;
device.backend.Tare), and a zero taken under it would read its push as the patient's
every tick after. A perfectly steady load cannot be told from the gauges' own offsets;
a hand is never that steady.

Saturation: a gauge at or beyond `saturation_V` (9.9 V of the ±10 V span) means
an overloaded sensor or a broken gauge wire; the reading is refused with
SensorRangeError, as is any axis beyond the calibration's rated `max`.
"""

from __future__ import annotations

import logging
import math
import time
import warnings
from collections.abc import Callable
from typing import Any

import numpy as np

from core.errors import capitalised
from device.backend import Tare, tare_of
from device.errors import (
    BackendError,
    BackendTimeout,
    BackendUnavailable,
    SensorRangeError,
    TareUnderLoad,
)
from device.hardware.atical import AXIS_NAMES, AtiCalibration, load_calibration
from device.hardware.settings import ForceSensorSettings

log = logging.getLogger(__name__)

NUM_GAUGES = 6

_INSTALL = (
    "Install NI's NI-DAQmx driver (ni.com, or `python -m nidaqmx installdriver`), check that "
    "NI MAX lists the card, then connect again."
)

# NI-DAQmx status codes we explain (nidaqmx.error_codes.DAQmxErrors).
_SAMPLES_NOT_YET_AVAILABLE = -200284
_SAMPLES_NO_LONGER_AVAILABLE = -200279
_INPUT_FIFO_OVERFLOW = -200010
_ADC_OVERRUN = -200019
_RESOURCE_ALREADY_RESERVED = -200022
_INVALID_TASK = -200088
_PHYSICAL_CHAN_DOES_NOT_EXIST = -200170
_INVALID_DEVICE_ID = -200220
_DEV_CANNOT_BE_ACCESSED = -201003
_INVALID_ATTRIBUTE_VALUE = -200077


def import_nidaqmx() -> dict[str, Any]:
    """The nidaqmx pieces we use, imported now (not at module import: it is optional)."""
    try:
        import nidaqmx
        from nidaqmx import constants, errors
        from nidaqmx.stream_readers import AnalogMultiChannelReader
    except (ImportError, OSError) as exc:
        raise BackendUnavailable(
            f"The force sensor needs the NI-DAQmx Python package, which cannot be imported "
            f"here ({type(exc).__name__}: {exc}). Install it into this Python environment with "
            f"`pip install nidaqmx==1.7.0`. {_INSTALL}"
        ) from exc
    return {
        "Task": nidaqmx.Task,
        "constants": constants,
        "errors": errors,
        "Reader": AnalogMultiChannelReader,
    }


class AtiForceSensor:
    """The Nano25 on an NI-DAQmx card: `open()` (configure + tare), `read()`, `close()`.

    `read()` returns (Fx, Fy, Fz) in N in the sensor's frame and keeps all six
    axes in `last_ft` (N, N·m). It allocates nothing but the returned tuple.
    """

    def __init__(
        self,
        settings: ForceSensorSettings,
        *,
        calibration: AtiCalibration | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.settings = settings
        self._calibration = calibration
        self._clock = clock
        self._api: dict[str, Any] | None = None
        self._task: Any = None
        self._reader: Any = None
        self._in_stream: Any = None
        self._matrix = np.eye(NUM_GAUGES)
        self._max = np.full(NUM_GAUGES, np.inf)
        self._bias = np.zeros(NUM_GAUGES)
        self._volts = np.zeros(NUM_GAUGES)
        self._tared = np.zeros(NUM_GAUGES)
        self._abs = np.zeros(NUM_GAUGES)
        self._ft = np.zeros(NUM_GAUGES)
        self._over = np.zeros(NUM_GAUGES, dtype=bool)
        self._last_total = -1
        self._last_new_s = math.nan
        self.tare: Tare | None = None
        """How the zero at the last `open()` went (None before one)."""

    # -- state
    @property
    def is_open(self) -> bool:
        return self._task is not None

    @property
    def calibration(self) -> AtiCalibration | None:
        return self._calibration

    @property
    def rated_range_N(self) -> tuple[float, float] | None:
        """(planar, normal) rated range from the calibration's `max` values: the lower of
        Fx and Fy, and Fz, in N. None before the calibration is loaded or when the file
        gives no maxima."""
        cal = self._calibration
        if cal is None:
            return None
        fx, fy, fz = cal.max_loads_SI[:3]
        if not (fx > 0.0 and fy > 0.0 and fz > 0.0):
            return None
        return (min(fx, fy), fz)

    @property
    def bias_V(self) -> np.ndarray:
        """The tare voltages G0..G5 (a copy)."""
        return self._bias.copy()

    @property
    def last_ft(self) -> np.ndarray:
        """The last reading's (Fx, Fy, Fz, Tx, Ty, Tz) in N and N·m (a read-only view)."""
        view = self._ft.view()
        view.setflags(write=False)
        return view

    # -- lifecycle
    def open(self) -> None:
        """Load the calibration, start the acquisition and tare. Raises BackendError."""
        if self._task is not None:
            return
        s = self.settings
        api = import_nidaqmx()
        if self._calibration is None:
            self._calibration = load_calibration(s.calibration_file, s.calibration_index)
        cal = self._calibration
        if cal.output_half_range_V > s.voltage_range_V + 1e-9:
            raise BackendError(
                f"The calibration {cal.path} says the sensor outputs "
                f"±{cal.output_half_range_V:g} V but [force_sensor] voltage_range_V is "
                f"±{s.voltage_range_V:g} V, which would clip large forces. Set voltage_range_V "
                "to the sensor's output range."
            )
        self._matrix = np.ascontiguousarray(cal.matrix_SI, dtype=np.float64)
        self._max = np.array([m if m > 0.0 else np.inf for m in cal.max_loads_SI])
        errors = api["errors"]
        try:
            task = api["Task"]()
        except errors.DaqNotFoundError as exc:
            raise BackendUnavailable(
                f"The NI-DAQmx driver is not installed on this computer ({exc}). {_INSTALL}"
            ) from exc
        except errors.Error as exc:
            raise BackendUnavailable(
                f"NI-DAQmx cannot run here ({type(exc).__name__}: {exc}). {_INSTALL}"
            ) from exc
        self._api = api
        self._task = task
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                self._configure(task, api)
                self._tare(api)
            for warning in caught:
                log.warning("NI-DAQmx warned while starting the force sensor: %s",
                            warning.message)
        except BaseException as exc:
            self._release()
            if isinstance(exc, errors.DaqError):
                tare_s = s.tare_samples / s.sample_rate_Hz + 1.0
                raise self._translate(exc, "starting the acquisition", tare_s) from exc
            raise
        if cal.software_temp_comp_available:
            log.info("%s offers software temperature compensation; it is not applied "
                     "(no thermistor channel is wired).", cal.path)
        log.info("Force sensor %s (%s, serial %s) tared on %s: bias %s V", cal.part_number,
                 cal.body_style, cal.serial, s.physical_channels,
                 np.array2string(self._bias, precision=4))

    def _configure(self, task: Any, api: dict[str, Any]) -> None:
        s = self.settings
        c = api["constants"]
        task.ai_channels.add_ai_voltage_chan(
            s.physical_channels,
            terminal_config=c.TerminalConfiguration[s.terminal_config],
            min_val=-s.voltage_range_V,
            max_val=s.voltage_range_V,
            units=c.VoltageUnits.VOLTS,
        )
        # In CONTINUOUS mode samps_per_chan sizes the circular buffer: one second,
        # and never less than the tare.
        buffer = max(int(s.sample_rate_Hz), s.tare_samples)
        task.timing.cfg_samp_clk_timing(
            s.sample_rate_Hz, sample_mode=c.AcquisitionType.CONTINUOUS, samps_per_chan=buffer
        )
        self._in_stream = task.in_stream
        self._in_stream.overwrite = c.OverwriteMode.OVERWRITE_UNREAD_SAMPLES
        self._reader = api["Reader"](self._in_stream)
        task.start()

    def _tare(self, api: dict[str, Any]) -> None:
        """Average the first `tare_samples` samples into the bias, then switch to newest-sample."""
        s = self.settings
        c = api["constants"]
        samples = np.zeros((NUM_GAUGES, s.tare_samples))
        timeout = s.tare_samples / s.sample_rate_Hz + 1.0
        self._reader.read_many_sample(samples, s.tare_samples, timeout=timeout)
        extreme = samples[np.arange(NUM_GAUGES), np.argmax(np.abs(samples), axis=1)]
        for gauge in range(NUM_GAUGES):
            if not abs(extreme[gauge]) < s.saturation_V:
                raise SensorRangeError(
                    f"Force sensor gauge G{gauge} reads {extreme[gauge]:+.3f} V during the tare, "
                    f"at the ±{s.voltage_range_V:g} V limit ({s.physical_channels}): the sensor is "
                    "overloaded or a gauge wire is broken. Make sure nobody touches the handle, "
                    "check the ATI cable and interface power, then connect again."
                )
        bias = samples.mean(axis=1)
        # the in-plane force of every sample about the mean: what moved during the zero
        fx, fy = self._matrix[:2] @ (samples - bias[:, None])
        self.tare = tare_of(fx, fy, s.tare_samples / s.sample_rate_Hz, s.tare_spread_limit_N)
        refused = self.tare.refusal()
        if refused:
            raise TareUnderLoad(capitalised(refused) + ".")
        self._bias[:] = bias
        self._in_stream.relative_to = c.ReadRelativeTo.MOST_RECENT_SAMPLE
        self._in_stream.offset = -1
        self._last_total = self._in_stream.total_samp_per_chan_acquired
        self._last_new_s = self._clock()

    def close(self) -> None:
        """Stop and release the acquisition. Safe to call twice; raises BackendError on failure."""
        if self._task is None:
            return
        errors = self._api["errors"] if self._api else None
        try:
            self._release(raise_errors=True)
        except Exception as exc:
            if errors is not None and isinstance(exc, errors.DaqError):
                raise self._translate(exc, "stopping the acquisition") from exc
            raise

    def _release(self, *, raise_errors: bool = False) -> None:
        task, self._task = self._task, None
        self._reader = None
        self._in_stream = None
        if task is None:
            return
        first: Exception | None = None
        for step in (task.stop, task.close):
            try:
                step()
            except Exception as exc:  # the task must be closed whatever stop() says
                first = first or exc
        if first is not None and raise_errors:
            raise first

    # -- the 2 ms tick
    def read(self) -> tuple[float, float, float]:
        """The newest (Fx, Fy, Fz) in N, sensor frame. Raises BackendError and subclasses."""
        if self._reader is None:
            raise BackendError("The force sensor is not connected: connect the robot first.")
        s = self.settings
        try:
            self._reader.read_one_sample(self._volts, timeout=s.read_timeout_s)
            total = self._in_stream.total_samp_per_chan_acquired
        except Exception as exc:
            errors = self._api["errors"]  # type: ignore[index]
            if isinstance(exc, errors.DaqError):
                raise self._translate(exc, "reading") from exc
            raise
        now = self._clock()
        if total != self._last_total:
            self._last_total = total
            self._last_new_s = now
        elif now - self._last_new_s > s.read_timeout_s:
            raise BackendTimeout(
                f"The force sensor's card ({s.physical_channels}) has delivered no new sample "
                f"for {(now - self._last_new_s) * 1e3:.0f} ms (limit "
                f"{s.read_timeout_s * 1e3:.0f} ms): the acquisition has stopped. Check the NI "
                "card's cable and power, then connect again."
            )
        np.abs(self._volts, out=self._abs)
        if not float(self._abs.max()) < s.saturation_V:
            raise self._saturated()
        np.subtract(self._volts, self._bias, out=self._tared)
        np.dot(self._matrix, self._tared, out=self._ft)
        np.abs(self._ft, out=self._abs)
        np.greater(self._abs, self._max, out=self._over)
        if self._over.any():
            raise self._over_range()
        return (float(self._ft[0]), float(self._ft[1]), float(self._ft[2]))

    def _saturated(self) -> SensorRangeError:
        s = self.settings
        bad = [g for g in range(NUM_GAUGES) if not abs(self._volts[g]) < s.saturation_V]
        gauge = bad[0]
        return SensorRangeError(
            f"Force sensor gauge G{gauge} reads {self._volts[gauge]:+.3f} V, at the "
            f"±{s.voltage_range_V:g} V limit (saturation set at {s.saturation_V:g} V, "
            f"{s.physical_channels}): the sensor is overloaded or a gauge wire is broken. Let go "
            "of the handle; if it persists check the ATI cable and interface power, then "
            "connect again (which tares the sensor)."
        )

    def _over_range(self) -> SensorRangeError:
        axis = int(np.argmax(self._over))
        unit = "N" if axis < 3 else "N·m"
        return SensorRangeError(
            f"Force sensor {AXIS_NAMES[axis]} reads {self._ft[axis]:+.1f} {unit}, beyond the "
            f"calibrated range of ±{self._max[axis]:g} {unit}: the handle is overloaded. Let go "
            "of the handle; the reading is not trustworthy beyond the rated range."
        )

    def _translate(self, exc: Any, action: str, timeout_s: float | None = None) -> BackendError:
        """A BackendError subclass that says what failed and what to do, for a DaqError."""
        s = self.settings
        timeout_s = s.read_timeout_s if timeout_s is None else timeout_s
        code = getattr(exc, "error_code", 0)
        where = f"the force sensor's NI card ({s.physical_channels})"
        first_line = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        detail = f"NI-DAQmx error {code}: {first_line}"
        device = s.physical_channels.split("/")[0]
        if code == _SAMPLES_NOT_YET_AVAILABLE:
            return BackendTimeout(
                f"{where} gave no sample within {timeout_s * 1e3:.0f} ms while {action} "
                f"({detail}). Check that the card is connected and powered, then connect again."
            )
        if code in (_SAMPLES_NO_LONGER_AVAILABLE, _INPUT_FIFO_OVERFLOW, _ADC_OVERRUN):
            return BackendError(
                f"{where} fell behind while {action} ({detail}): the computer did not keep up "
                "with the card. Close other programs and connect again."
            )
        if code == _RESOURCE_ALREADY_RESERVED:
            return BackendUnavailable(
                f"{where} is in use by another program ({detail}). Close NI MAX test panels, "
                "LabVIEW or another console, then connect again."
            )
        if code in (_INVALID_DEVICE_ID, _DEV_CANNOT_BE_ACCESSED):
            return BackendUnavailable(
                f"NI device {device!r} cannot be found or accessed ({detail}). Check the cable "
                "and power, and that NI MAX shows the card under that name; correct "
                "[force_sensor] physical_channels if the name differs."
            )
        if code == _PHYSICAL_CHAN_DOES_NOT_EXIST:
            return BackendError(
                f"{s.physical_channels!r} names inputs the card does not have ({detail}). "
                "Correct [force_sensor] physical_channels (six inputs, G0..G5 in order)."
            )
        if code == _INVALID_ATTRIBUTE_VALUE:
            return BackendError(
                f"{where} refused a setting ({detail}). Check [force_sensor] terminal_config "
                f"({s.terminal_config}), voltage_range_V ({s.voltage_range_V:g}) and "
                f"sample_rate_Hz ({s.sample_rate_Hz:g}) against the card's specifications."
            )
        if code == _INVALID_TASK:
            return BackendError(
                f"{where}: the acquisition task no longer exists ({detail}). Connect again."
            )
        return BackendError(f"{where} failed while {action} ({detail}). Connect again; if it "
                            "recurs, note the error number for the technician.")
