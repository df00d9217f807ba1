"""Surface EMG from the instruments beside the robot: files a Delsys Trigno (or any system)
exported (`files`), a Trigno base station live over the Trigno Control Utility's TCP
protocol (`trigno`), any EMG stream of the Lab Streaming Layer and an outlet of the robot's
own state (`lsl`), and the capture thread that keeps a source's samples on the monotonic
clock while a trial runs (`capture`).

EMG never runs in the loop process: a source is read on its own thread in the console
process, so the robot's trial is never held up by EMG (docs/architecture.md). This room
knows neither the loop nor the trial file; app.emg joins them. pylsl is imported only
in `lsl`, when a stream is opened.
"""
