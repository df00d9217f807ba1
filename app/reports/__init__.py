"""What patients and therapists read: the post-trial report (content, plain language,
comparison with the last trial and session, the PDF), a patient's progress across
sessions, metric tables in display units, and the reachability check as text.

May import core, device, app.records and app.trials. Never Qt: the PDF is drawn with
matplotlib.
"""
