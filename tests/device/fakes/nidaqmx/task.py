"""Fake of `nidaqmx.task.Task` (1.7.0) for analog-input voltage tasks.

Behaviour kept from the real package and driver:
* `Task()` raises `DaqNotFoundError` (not a DaqError) when the driver is missing;
* `close()` (alias `clear()`) releases the task; a second close warns
  `DaqResourceWarning`; a task garbage-collected unclosed warns the same;
* `add_ai_voltage_chan` defaults to ±5 V and the DEFAULT terminal configuration,
  and calls `.value` on its enum arguments (strings fail as in the real one);
* unknown devices raise -200220, channels beyond the device -200170, an
  unsupported terminal configuration -200077 at start, a device reserved by
  another task -200022, a disconnected one -201003;
* reads honour `in_stream.relative_to` / `offset`; a read that cannot be served
  within `timeout` raises `DaqReadError` -200284; samples overwritten in the
  circular buffer raise -200279.
"""

from __future__ import annotations

import math
import re
import warnings

import numpy as np

from nidaqmx import _fake
from nidaqmx.constants import (
    READ_ALL_AVAILABLE,
    AcquisitionType,
    Edge,
    OverwriteMode,
    ReadRelativeTo,
    TerminalConfiguration,
    VoltageUnits,
)
from nidaqmx.error_codes import DAQmxErrors
from nidaqmx.errors import DaqError, DaqNotFoundError, DaqReadError, DaqResourceWarning

_DAQ_NOT_FOUND_MESSAGE = (
    "Could not find an installation of NI-DAQmx. Please ensure that NI-DAQmx "
    "is installed on this machine or contact National Instruments for support."
)
_CHANNEL = re.compile(r"^\s*([A-Za-z0-9_\-]+)/ai(\d+)(?::(\d+))?\s*$")


class _Channel:
    def __init__(self, device, index, minimum, maximum, terminal) -> None:
        self.device = device
        self.index = index
        self.min_val = minimum
        self.max_val = maximum
        self.terminal = terminal


class AIChannelCollection:
    def __init__(self, task: Task) -> None:
        self._task = task

    def add_ai_voltage_chan(
        self, physical_channel, name_to_assign_to_channel="",
        terminal_config=TerminalConfiguration.DEFAULT, min_val=-5.0,
        max_val=5.0, units=VoltageUnits.VOLTS, custom_scale_name="",
    ):
        task = self._task
        task._check_open()
        terminal = terminal_config.value
        units.value  # noqa: B018 - the real call passes units.value to C
        if not min_val < max_val or max(abs(min_val), abs(max_val)) > 10.0:
            raise DaqError("Requested value is not a supported value for this property.",
                           DAQmxErrors.INVALID_ATTRIBUTE_VALUE, task.name)
        for item in physical_channel.split(","):
            match = _CHANNEL.match(item)
            if match is None:
                raise DaqError(f"Physical channel name is invalid: {item}",
                               DAQmxErrors.PHYSICAL_CHAN_DOES_NOT_EXIST, task.name)
            device = _fake.system.devices.get(match.group(1))
            if device is None:
                raise DaqError(f"Device identifier is invalid: {match.group(1)}",
                               DAQmxErrors.INVALID_DEVICE_ID, task.name)
            first = int(match.group(2))
            last = int(match.group(3)) if match.group(3) is not None else first
            step = 1 if last >= first else -1
            for index in range(first, last + step, step):
                if index >= device.ai_channels:
                    raise DaqError(
                        f"Physical channel specified does not exist on this device: "
                        f"{device.name}/ai{index}",
                        DAQmxErrors.PHYSICAL_CHAN_DOES_NOT_EXIST, task.name,
                    )
                task._channels.append(_Channel(device, index, float(min_val), float(max_val),
                                               terminal))
        return None


class Timing:
    def __init__(self, task: Task) -> None:
        self._task = task
        self.samp_quant_samp_mode = AcquisitionType.FINITE
        self.samp_quant_samp_per_chan = 1000
        self.samp_clk_rate = 0.0
        self.configured = False

    def cfg_samp_clk_timing(
        self, rate, source="", active_edge=Edge.RISING,
        sample_mode=AcquisitionType.FINITE, samps_per_chan=1000,
    ):
        self._task._check_open()
        active_edge.value  # noqa: B018 - the real call passes the enum values to C
        sample_mode.value  # noqa: B018
        if samps_per_chan < 0 or not rate > 0:
            raise DaqError("Requested value is not a supported value for this property.",
                           DAQmxErrors.INVALID_ATTRIBUTE_VALUE, self._task.name)
        self.samp_clk_rate = float(rate)
        self.samp_quant_samp_mode = sample_mode
        self.samp_quant_samp_per_chan = int(samps_per_chan)
        self.configured = True


class InStream:
    def __init__(self, task: Task) -> None:
        self._task = task
        self._relative_to = ReadRelativeTo.CURRENT_READ_POSITION
        self._offset = 0
        self._overwrite = OverwriteMode.DO_NOT_OVERWRITE_UNREAD_SAMPLES

    @property
    def num_chans(self) -> int:
        return len(self._task._channels)

    @property
    def relative_to(self):
        return self._relative_to

    @relative_to.setter
    def relative_to(self, val):
        val.value  # noqa: B018 - the real setter passes val.value to C
        self._relative_to = val

    @property
    def offset(self) -> int:
        return self._offset

    @offset.setter
    def offset(self, val):
        self._offset = int(val)

    @property
    def overwrite(self):
        return self._overwrite

    @overwrite.setter
    def overwrite(self, val):
        val.value  # noqa: B018
        self._overwrite = val

    @property
    def total_samp_per_chan_acquired(self) -> int:
        self._task._check_open()
        return self._task._acquired()

    @property
    def avail_samp_per_chan(self) -> int:
        self._task._check_open()
        return max(0, self._task._acquired() - self._task._read_pos)

    @property
    def curr_read_pos(self) -> int:
        return self._task._read_pos

    @property
    def input_buf_size(self) -> int:
        return self._task._buffer_size()


class Task:
    def __init__(self, new_task_name="", *, grpc_options=None) -> None:
        self._handle = None
        self._close_on_exit = False
        self._saved_name = new_task_name
        system = _fake.system
        if not system.driver_installed:
            raise DaqNotFoundError(_DAQ_NOT_FOUND_MESSAGE)
        system.tasks_created += 1
        self._handle = system.tasks_created
        self._close_on_exit = True
        self._saved_name = new_task_name or f"_unnamedTask<{self._handle - 1}>"
        system.open_tasks.add(self._handle)
        system.tasks.append(self)
        self._channels: list[_Channel] = []
        self._ai_channels = AIChannelCollection(self)
        self._timing = Timing(self)
        self._in_stream = InStream(self)
        self._running = False
        self._start_s = 0.0
        self._read_pos = 0
        self._on_demand_count = 0

    def __del__(self) -> None:
        if self._handle is not None and self._close_on_exit:
            warnings.warn(
                f'Task of name "{self._saved_name}" was not explicitly closed before it was '
                "destructed. Resources on the task device may still be reserved.",
                DaqResourceWarning, stacklevel=1,
            )

    def __enter__(self):
        return self

    def __exit__(self, type, value, traceback):
        if self._close_on_exit:
            self.close()

    @property
    def name(self) -> str:
        return self._saved_name

    @property
    def ai_channels(self) -> AIChannelCollection:
        return self._ai_channels

    @property
    def timing(self) -> Timing:
        return self._timing

    @property
    def in_stream(self) -> InStream:
        return self._in_stream

    @property
    def number_of_channels(self) -> int:
        return len(self._channels)

    def _check_open(self) -> None:
        if self._handle is None:
            raise DaqError("Task specified is invalid or does not exist.",
                           DAQmxErrors.INVALID_TASK, self._saved_name)

    def start(self) -> None:
        self._check_open()
        for device in {c.device.name: c.device for c in self._channels}.values():
            if device.disconnected:
                raise DaqError("Device cannot be accessed.", DAQmxErrors.DEV_CANNOT_BE_ACCESSED,
                               self.name)
            holder = _fake.system.reserved.get(device.name)
            if device.reserved_elsewhere or (holder is not None and holder != self._handle):
                raise DaqError("The specified resource is reserved.",
                               DAQmxErrors.RESOURCE_ALREADY_RESERVED, self.name)
        for channel in self._channels:
            allowed = {TerminalConfiguration[n].value for n in channel.device.terminal_configs}
            if channel.terminal != TerminalConfiguration.DEFAULT.value and \
                    channel.terminal not in allowed:
                raise DaqError(
                    "Requested value is not a supported value for this property.\n"
                    "Property: DAQmx_AI_TermCfg",
                    DAQmxErrors.INVALID_ATTRIBUTE_VALUE, self.name,
                )
        if self._timing.configured and self._timing.samp_clk_rate > min(
            c.device.max_rate_Hz for c in self._channels
        ) / max(1, len(self._channels)):
            raise DaqError("Requested value is not a supported value for this property.\n"
                           "Property: DAQmx_SampClk_Rate",
                           DAQmxErrors.INVALID_ATTRIBUTE_VALUE, self.name)
        for channel in self._channels:
            _fake.system.reserved[channel.device.name] = self._handle
        self._running = True
        self._start_s = _fake.system.clock.now()
        self._read_pos = 0

    def stop(self) -> None:
        self._check_open()
        self._running = False
        self._release()

    def close(self) -> None:
        if self._handle is None:
            warnings.warn(
                f'Attempted to close NI-DAQmx task of name "{self._saved_name}" but task was '
                "already closed.", DaqResourceWarning, stacklevel=2,
            )
            return
        self._running = False
        self._release()
        _fake.system.open_tasks.discard(self._handle)
        self._handle = None

    clear = close

    def _release(self) -> None:
        for name, holder in list(_fake.system.reserved.items()):
            if holder == self._handle:
                del _fake.system.reserved[name]

    # -- acquisition
    def _buffer_size(self) -> int:
        if self._timing.samp_quant_samp_mode is AcquisitionType.CONTINUOUS:
            return max(self._timing.samp_quant_samp_per_chan, 1)
        return self._timing.samp_quant_samp_per_chan

    def _acquired(self) -> int:
        if not self._running or not self._timing.configured:
            return self._on_demand_count
        elapsed = _fake.system.clock.now() - self._start_s
        total = math.floor(elapsed * self._timing.samp_clk_rate + 1e-9)
        if self._timing.samp_quant_samp_mode is AcquisitionType.FINITE:
            total = min(total, self._timing.samp_quant_samp_per_chan)
        stall = min((c.device.stall_after for c in self._channels
                     if c.device.stall_after is not None), default=None)
        return total if stall is None else min(total, stall)

    def _value(self, channel: _Channel, k: int) -> float:
        volts = float(channel.device.sample(k)[channel.index])
        return min(max(volts, channel.min_val), channel.max_val)

    def _read_into(self, data: np.ndarray, count: int, timeout: float) -> int:
        """Fill data (channels × count, GROUP_BY_CHANNEL) and return samples read per channel."""
        self._check_open()
        for device in {c.device.name: c.device for c in self._channels}.values():
            if device.disconnected:
                raise DaqReadError("Device cannot be accessed.",
                                   DAQmxErrors.DEV_CANNOT_BE_ACCESSED, 0, self.name)
            if device.fail_read is not None:
                code, device.fail_read = device.fail_read, None
                raise DaqReadError("Injected read failure.", code, 0, self.name)
        if not self._running:
            self.start()  # reads auto-start a task, as DAQmx does
        if not self._timing.configured:
            # On demand: every read converts one fresh sample.
            first = self._on_demand_count
            self._on_demand_count += count
            for j in range(count):
                for i, channel in enumerate(self._channels):
                    data[i, j] = self._value(channel, first + j)
            return count
        clock = _fake.system.clock
        limit = 60.0 if timeout < 0 else timeout  # WAIT_INFINITELY: a fake must not hang
        deadline = clock.now() + limit
        period = 1.0 / self._timing.samp_clk_rate
        while True:
            total = self._acquired()
            relative = self._in_stream.relative_to
            if relative is ReadRelativeTo.MOST_RECENT_SAMPLE:
                position = total + self._in_stream.offset
            elif relative is ReadRelativeTo.FIRST_SAMPLE:
                position = self._in_stream.offset
            else:
                position = self._read_pos + self._in_stream.offset
            if position >= 0 and position + count <= total:
                break
            if clock.now() >= deadline:
                if timeout < 0:
                    raise RuntimeError("fake nidaqmx: a read would wait forever")
                raise DaqReadError(
                    "Some or all of the samples requested have not yet been acquired.\n"
                    "To wait for the samples to become available use a longer read timeout "
                    "or read later in your program.",
                    DAQmxErrors.SAMPLES_NOT_YET_AVAILABLE, 0, self.name,
                )
            clock.sleep(min(period, max(deadline - clock.now(), 0.0)))
        if position < total - self._buffer_size():
            raise DaqReadError(
                "The application is not able to keep up with the hardware acquisition.\n"
                "Samples requested are no longer available: they have been overwritten.",
                DAQmxErrors.SAMPLES_NO_LONGER_AVAILABLE, 0, self.name,
            )
        for j in range(count):
            for i, channel in enumerate(self._channels):
                data[i, j] = self._value(channel, position + j)
        self._read_pos = position + count
        return count

    def _calculate_num_samps_per_chan(self, num_samps_per_chan) -> int:
        if num_samps_per_chan == READ_ALL_AVAILABLE:
            if self._timing.samp_quant_samp_mode is AcquisitionType.FINITE:
                return self._timing.samp_quant_samp_per_chan
            return self._in_stream.avail_samp_per_chan
        return num_samps_per_chan
