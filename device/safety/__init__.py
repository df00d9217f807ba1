"""The safety supervisor and what it knows. docs/safety.md is its safety case.

`checks`: the per-tick checks as kernels (core.kernels), one function per check,
`first_failure` that runs them in the order of docs/safety.md, the torque clamp, and
`supervise`, one tick; the only copy of the checks, run interpreted by the supervisor and
compiled by the loop's tick engine. `supervisor`: SafetySupervisor, which validates the
limits against the robot's drives, owns the checks' constants and state vectors, latches
faults until cleared and builds a latched fault's detail and banner (`after_tick`).
`limits`: SafetyLimits, with why each limit has its value. `faults`: the fault codes with
their plain-language messages.

May import core and device.backend and device.errors only: the last word before the
motors depends on nothing that could fail with the loop, the recorder, a device or the
compiler (device.compiled compiles its kernels from outside).
"""
