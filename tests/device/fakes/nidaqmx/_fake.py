"""The simulated NI-DAQmx driver behind the fake `nidaqmx` (test control surface; not real API).

A `FakeDevice` samples its analog inputs on a clock: sample k of a running,
hardware-timed task is taken at `start + k / rate` and holds `source(k)` (one
voltage per physical channel of the device), clipped to the channel's input
range as an ADC clips. Tests drive time with `ManualClock` (reads that must wait
advance it, so nothing sleeps) or use the real clock.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np


class RealClock:
    def now(self) -> float:
        return time.monotonic()

    def sleep(self, seconds: float) -> None:
        time.sleep(max(0.0, seconds))


class ManualClock:
    """Time that moves only when told to, or when a read waits for samples."""

    def __init__(self, start_s: float = 1000.0) -> None:
        self.t = start_s

    def now(self) -> float:
        return self.t

    def sleep(self, seconds: float) -> None:
        self.t += max(0.0, seconds)

    def advance(self, seconds: float) -> None:
        self.t += seconds


class FakeDevice:
    """A simulated multifunction DAQ card (e.g. a PCIe-6321: 16 single-ended / 8 differential)."""

    def __init__(
        self,
        name: str = "Dev1",
        ai_channels: int = 16,
        terminal_configs: tuple[str, ...] = ("RSE", "NRSE", "DIFF"),
        max_rate_Hz: float = 250_000.0,
    ) -> None:
        self.name = name
        self.ai_channels = ai_channels
        self.terminal_configs = terminal_configs
        self.max_rate_Hz = max_rate_Hz
        self.volts = np.zeros(ai_channels)
        """What every input reads when `source` is not set (constant voltages)."""
        self.source: Callable[[int], np.ndarray] | None = None
        """Sample index -> voltages of all inputs; overrides `volts`."""
        self.stall_after: int | None = None
        """Acquisition silently stops after this many samples (a hung device)."""
        self.reserved_elsewhere = False
        self.disconnected = False
        self.fail_read: int | None = None
        """Error code the next read raises (then cleared)."""

    def sample(self, k: int) -> np.ndarray:
        if self.source is not None:
            return np.asarray(self.source(k), dtype=np.float64)
        return self.volts.copy()


class FakeSystem:
    def __init__(self) -> None:
        self.driver_installed = True
        self.devices: dict[str, FakeDevice] = {}
        self.clock: RealClock | ManualClock = RealClock()
        self.open_tasks: set[int] = set()
        self.tasks_created = 0
        self.tasks: list = []
        """Every Task created, for tests to inspect (closed ones included)."""
        self.reserved: dict[str, int] = {}
        """Device name -> handle of the running task that reserved it."""


system = FakeSystem()


def fake_reset() -> FakeSystem:
    global system
    system.__init__()  # type: ignore[misc]
    return system


def fake_install_device(device: FakeDevice | None = None, **kwargs) -> FakeDevice:
    device = device or FakeDevice(**kwargs)
    system.devices[device.name] = device
    return device
