"""The window's view models: what the tabs show, computed without Qt, so they can be
tested and reused without a display. The "Only ui imports Qt" contract covers them.

One module per view model: trialview (a trial's arrays and running figures), samples
(which samples a plot draws), numbers (how a figure reads), moment (a replayed
moment in words), reach (a trial's check as the Parameters tab shows it),
progress_table (a patient's progress in words) and loop_health (the status bar's
loop line).
"""
