"""A patient in the Registration tab's words: one line for the list of patients found,
what the registry holds of their measurements, and where their names are kept
(ui.tabs.registration)."""

from __future__ import annotations

from app.records.registry import Patient
from app.units import cm, point_cm


def describe(patient: Patient) -> str:
    """One line for the list: name, code and what tells two namesakes apart."""
    parts = [f"{patient.display_name} — {patient.code}"]
    if patient.birth_year:
        parts.append(f"born {patient.birth_year}")
    if patient.side:
        parts.append(f"{patient.side} arm")
    return ", ".join(parts)


PATIENT_MEASUREMENTS = {"body_mass": "body_mass_kg", "upper_arm": "upper_arm_m",
                        "forearm": "forearm_m", "shoulder": "shoulder_m"}
"""The Parameters form's rows (their error keys) a registered patient may have stored, by
the Patient's attribute (ui.tabs.parameters refuses the ones not stored until given)."""
MEASUREMENT_WORDS = {"body_mass": "body mass", "upper_arm": "upper arm", "forearm": "forearm",
                     "shoulder": "shoulder position"}
_STORED_WORDS = {"body_mass": lambda v: f"body mass {v:.1f} kg",
                 "upper_arm": lambda v: f"upper arm {cm(v)}",
                 "forearm": lambda v: f"forearm {cm(v)}",
                 "shoulder": lambda v: f"shoulder at {point_cm(v)}"}


def measurements(patient: Patient) -> str:
    """The patient's stored measurements, in the form's units (kg, cm), and the ones not
    stored, named."""
    stored, missing = [], []
    for key, attribute in PATIENT_MEASUREMENTS.items():
        value = getattr(patient, attribute)
        if value is None:
            missing.append(MEASUREMENT_WORDS[key])
        else:
            stored.append(_STORED_WORDS[key](value))
    # the form's values for what is not stored are not this patient's (another patient's,
    # the last trial's): the Parameters tab refuses them until given and kept in the record
    # (ui.tabs.parameters.apply_patient); name them, so the therapist knows what to measure
    if not stored:
        return ("No measurements stored: give the body mass, arm lengths and shoulder "
                "position in the Parameters tab, which keeps them in the patient's record "
                "and refuses its values until then.")
    said = "Stored: " + ", ".join(stored) + ". The Parameters tab now uses them."
    if not missing:
        return said
    them = "it" if len(missing) == 1 else "them"
    return (f"{said} Not stored: the {' and the '.join(missing)}; give {them} in the "
            "Parameters tab, which keeps them in the patient's record and refuses its "
            "values until then.")


def names_note(registry) -> str:
    """Where the patients' names are kept, as the tab says it: this computer's registry,
    or on a station the department's shared one (which said "this computer's")."""
    shared = registry is not None and bool(registry.location())
    where = ("the department's shared registry, which only the clinic's logins read"
             if shared else "this computer's registry")
    return f"Names stay in {where}. Files and reports carry only the patient's code."
