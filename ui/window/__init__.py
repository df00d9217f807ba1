"""The console's window by job: each module is one part of `ui.main_window.MainWindow`
(a mixin of it), so that each job reads on its own.

* `trial` — the robot buttons and a trial's life: Build, Connect, Start, Stop, Save, the
  loop's answers and states, the trial's end and its finishing.
* `trial_emg` — the live EMG source's part of a trial, into its file.
* `fault_latch` — the emergency stop, the fault banner and its Clear fault.
* `message_line` — the event line, its history, the status bar.
* `settings` — what the window remembers between sessions, and closing it.
"""
