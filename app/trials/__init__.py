"""One trial, after or without the robot: reading its file (also while it is recorded),
its metrics, a whole trial simulated headless, and finishing a trial into the records.

May import core, device and app.records.
"""
