"""The thesis robot's real hardware: the Quanser Q8 card (encoders, amplifiers,
watchdog), the ATI Nano25 force sensor through an NI-DAQmx card with its calibration
file, and the hardware settings file (docs/hardware.md).

May import core, device.backend and device.errors; the vendor APIs (quanser.hardware,
nidaqmx) only when a backend opens. Never device.sim.
"""
