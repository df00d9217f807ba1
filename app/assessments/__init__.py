"""The assessment battery at the console (issue 31): a task's figures from its recorded
trial (`figures`, which app.trials.analysis adds to every assessment trial's metrics, so
the file and the registry hold them whichever way the trial ran), and running a task or the
whole battery on the simulator headless (`runner`).

Imports core, device and app.trials/app.records, never app.cli or ui.
"""
