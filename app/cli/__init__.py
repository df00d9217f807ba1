"""The `rehab` command line: one module per command group (check, run, records, reports,
exports), what they share (common, trial_options), and `main`, which builds the parser
from the groups and dispatches. The groups never import `main`.

May import everything in app, device and core. Nothing here is imported by the rest of
app.
"""
