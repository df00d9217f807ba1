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
    parts = []
    if patient.body_mass_kg is not None:
        parts.append(f"body mass {patient.body_mass_kg:.1f} kg")
    if patient.upper_arm_m is not None:
        parts.append(f"upper arm {cm(patient.upper_arm_m)}")
    if patient.forearm_m is not None:
        parts.append(f"forearm {cm(patient.forearm_m)}")
    if patient.shoulder_m is not None:
        parts.append(f"shoulder at {point_cm(patient.shoulder_m)}")
    # the form's values for what is not stored are not this patient's (another patient's,
    # the last trial's): the Parameters tab refuses them until given
    # (ui.tabs.parameters.apply_patient)
    given = "give them in the Parameters tab, which refuses its values until then"
    if not parts:
        return f"No measurements stored: {given}."
    missing = 4 - len(parts)
    rest = f" For the others, {given}." if missing else ""
    return "Stored: " + ", ".join(parts) + ". The Parameters tab now uses them." + rest


def names_note(registry) -> str:
    """Where the patients' names are kept, as the tab says it: this computer's registry,
    or on a station the department's shared one (which said "this computer's")."""
    shared = registry is not None and bool(registry.location())
    where = ("the department's shared registry, which only the clinic's logins read"
             if shared else "this computer's registry")
    return f"Names stay in {where}. Files and reports carry only the patient's code."
