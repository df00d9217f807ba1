"""The `rehab` command line: one module per command group.

May import everything in app, device and core. Nothing here is imported by the rest of
app.
"""
