"""The patient's screen: a second window, for a second monitor or full screen on one,
that shows the patient the exercise, the hand and when to go (issue 30). Its content and
geometry are ui.views.patient_screen and ui.views.patient_geometry; here it is painted
(window) and opened, placed and fed from the therapist's window (control)."""
