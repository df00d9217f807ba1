"""The compiled tick: the simulator, the controllers, the assistance and the safety
supervisor's per-tick arithmetic, compiled with numba for headless trials.

Why: a headless trial in Python costs about 25 µs a tick (the interpreter, not the
arithmetic), 80–100× real time; compiled, the same arithmetic runs at well over
500× real time. The Python classes (device.simulator, device.patients,
core.control, device.supervisor) stay the reference: they are what the live loop and
anything unusual (a learned model in the controller, RK4, a custom patient) use, and
the compiled path must give the same records bit for bit on the configurations it
accepts (tests/device/test_compiled.py). Anything out of the ordinary in a compiled
run (a safety check that trips, an arm stretched straight, a sensor over its range)
hands the trial back to the Python path, which replays it and writes the exact event.

Modules: `jit` (numba set-up and cache), `dynamics` (coupled robot and arm, virtual
patients, sensors), `control` (rate estimator, SMC, CT-PID, assistance), `guard`
(the supervisor's checks and clamp), `trial` (the headless trial loop and its
packing from the Python objects).
"""
