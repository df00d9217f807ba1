"""The clinic's records: the registry of patients, sessions and trials (`app.records.registry`,
behind the interface `app.records.store.RecordStore`), the data folder that holds them,
the user's settings and the logs.

May import core, device.recording (trial-file names and statuses), device.sim.patient_parameters
(the virtual patients' names) and the standard library's sqlite3. Never Qt, never the loop.
"""
