"""The 2 ms control loop in its own process, and how the console drives it.

`process` runs the loop (DeviceLoop, loop_main): one tick path, and each state's entry,
leave and during behaviour; `engine` is the tick engine (TickEngine: one connection's
tick, a compiled simulator's whole tick in one call; `run_ticks` and `run_trial` for a
headless trial); `pipeline` the per-tick computation up to the commanded torque (the
kernel `control`) and the trial's reference; `backends` builds the backend a
BackendConfig names; `states` the loop's state machine (the TRANSITIONS table);
`messages` what the processes say to each other; `client` the console's side;
`realtime` what the OS allows for a 2 ms period, the loop's clocks and the wake-up check.

May import core, device.backend, device.errors, device.safety, device.recording and
device.sim (the tick engine runs the simulator's physics kernels); device.hardware only
inside the loop process, when Connect builds a hardware backend (`backends`);
device.compiled only where a tick runs compiled (the loop process, a headless run).
Never Qt, matplotlib or the app's settings.
"""
