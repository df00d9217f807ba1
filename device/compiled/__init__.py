"""The compiled tick: the simulator, the controllers, the assistance and the safety
supervisor's per-tick arithmetic, compiled with numba for headless trials and for the
live loop's running tick on the simulator.

Why: a tick in Python costs about 25 µs (the interpreter, not the arithmetic): 80–100×
real time headless, and 100–200 µs at the 99th percentile in the sleeping loop
process. Compiled, a headless trial runs at about 1,000× real time and the loop's
tick at 20–40 µs p99. The Python classes (device.sim.simulator, device.sim.patients,
core.control, device.safety.supervisor) stay the reference and the owners of the state:
anything unusual (a learned model in the controller, RK4, a custom patient, the
hardware) runs there, and the compiled path must give the same records bit for bit
on the configurations it accepts (tests/device/test_compiled*.py). Anything out of
the ordinary in a compiled run (a safety check that trips, an arm stretched
straight, a sensor over its range) is handed back to the Python path, which runs it
again and writes the exact event.

Modules: `cachedir` and `jit` (numba set-up and its cache), `dynamics` (coupled robot
and arm, virtual patients, sensors), `control` (rate estimator, SMC, CT-PID,
assistance), `guard` (the supervisor's checks and clamp), `trial` (a headless trial),
`looptick` (the live loop's running tick, with its hand-over to the Python objects),
`warmup` (loading the kernels ahead of use). docs/performance.md has the figures.
"""
