"""The safety supervisor and what it knows: the limits (with why each has its value), the
fault codes with their plain-language messages, and the supervisor that checks every
tick, clamps the torque and latches faults. docs/safety.md is its safety case.

May import core and device.backend and device.errors only: the last word before the
motors depends on nothing that could fail with the loop, the recorder or the window.
"""
