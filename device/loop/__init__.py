"""The 2 ms control loop in its own process, and how the console drives it.

`process` runs the loop (DeviceLoop, loop_main); `pipeline` is the per-tick
computation a trial shares with headless runs; `states` the loop's state machine;
`messages` what the processes say to each other; `client` the console's side;
`realtime` what the OS allows for a 2 ms period.

May import core, device.backend, device.errors, device.safety, device.recording, and,
inside the loop process only, device.sim, device.hardware and device.compiled (built at
Connect from a BackendConfig). Never Qt, matplotlib or the app's settings.
"""
