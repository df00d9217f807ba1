"""The clinic's records: the registry of patients, sessions and trials, the data folder
that holds them, the user's settings and the logs.

May import core, device.recording (trial-file names) and the standard library's sqlite3.
Never Qt, never the loop.
"""
