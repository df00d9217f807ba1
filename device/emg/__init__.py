"""Surface EMG from the instruments beside the robot: files a Delsys Trigno (or any system)
exported (`files`; the Delsys layouts in `delsys`, mixed EMG rates in `channels`), a
Trigno base station live over the Trigno Control Utility's TCP protocol (`trigno`), and
the capture thread that keeps a source's samples on the monotonic clock while a trial runs
(`capture`); any EMG stream of the Lab Streaming Layer is read by
device.lsl.inlet.

EMG never runs in the loop process: a source is read on its own thread in the console
process, so the robot's trial is never held up by EMG (docs/architecture.md). This room
knows neither the loop nor the trial file; app.emg joins them.
"""
