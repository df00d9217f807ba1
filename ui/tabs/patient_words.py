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


def measurements(patient: Patient) -> str:
    """The patient's stored measurements, in the form's units (kg, cm), and what happens
    to the ones not stored."""
    stored, missing = [], []
    for value, words, what in (
            (patient.body_mass_kg, lambda v: f"body mass {v:.1f} kg", "body mass"),
            (patient.upper_arm_m, lambda v: f"upper arm {cm(v)}", "upper arm"),
            (patient.forearm_m, lambda v: f"forearm {cm(v)}", "forearm"),
            (patient.shoulder_m, lambda v: f"shoulder at {point_cm(v)}",
             "shoulder position")):
        (stored if value is not None else missing).append(
            words(value) if value is not None else what)
    # the form's values for what is not stored are not this patient's (another patient's,
    # the last trial's): the Parameters tab refuses them until given
    # (ui.tabs.parameters.apply_patient); name them, so the therapist knows what to measure
    if not stored:
        return ("No measurements stored: give the body mass, arm lengths and shoulder "
                "position in the Parameters tab, which refuses its values until then.")
    said = "Stored: " + ", ".join(stored) + ". The Parameters tab now uses them."
    if not missing:
        return said
    them = "it" if len(missing) == 1 else "them"
    return (f"{said} Not stored: the {' and the '.join(missing)}; give {them} in the "
            "Parameters tab, which refuses its values until then.")


def names_note(registry) -> str:
    """Where the patients' names are kept, as the tab says it: this computer's registry,
    or on a station the department's shared one (which said "this computer's")."""
    shared = registry is not None and bool(registry.location())
    where = ("the department's shared registry, which only the clinic's logins read"
             if shared else "this computer's registry")
    return f"Names stay in {where}. Files and reports carry only the patient's code."
