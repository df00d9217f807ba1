"""The compiled flavour of the per-tick kernels: numba, its cache, and loading ahead of use.

Every per-tick formula (the robot's and the arm's terms, the coupled dynamics, the
virtual patients, the simulator's integrator and sensors, the rate trackers, the
controllers, the assistance, the safety supervisor's checks, the tick engine) is
written once, as a kernel in the package it belongs to (core.kernels says what a
kernel is). This package only compiles those same functions: `jit.compiled(f)` is f
compiled with every kernel it calls; `cachedir` says where numba keeps the machine code
and why it is keyed by the kernels' sources; `warmup` compiles or loads the kernels
before a tick or a timed run needs them.

Why compile: a tick interpreted costs tens of µs (the interpreter, not the arithmetic);
compiled, a headless trial runs at about a thousand times real time and the loop's tick
at tens of µs at its 99th percentile (docs/performance.md). Interpreted, the same
kernels are the reference the tests hold the compiled ones to, bit for bit.

May import core, device.backend, device.sim, device.loop and device.safety (`warmup`,
to run their kernels once) and numba (`jit`). `jit` is imported only where a kernel runs
compiled: in the loop process, a headless run and the warm-up, so the console's window
never loads numba.
"""
