"""The registry's patients: who they are, their arm's measurements, and finding them.

Here the patient is found by name (`find_patients`, what the registration tab
checks before `create_patient`, which gives a new patient a pseudonymous code).
Names live only in the `patients` table and never reach the log; every file is
named by code. Names are matched ignoring case and accents.
"""

from __future__ import annotations

import datetime
import logging
import secrets
import unicodedata
from dataclasses import dataclass
from pathlib import Path

import sqlalchemy as sa

from app.errors import InvalidRecordError, PatientNotFound, RegistryError
from app.records.datadir import CODE_ALPHABET, CODE_PATTERN
from app.records.registry.database import Database
from app.records.registry.statements import execute
from app.records.registry.values import (
    NAME_MAX_CHARS,
    TEXT_MAX_CHARS,
    checked_text,
    utc_now,
    utc_text,
)
from core.arm import BODY_MASS_RANGE_KG, FOREARM_RANGE_M, UPPER_ARM_RANGE_M
from core.errors import CoreError, check_range
from core.trial import POSITION_RANGE_M, SIDES

# The registry's one logger, named as it was before the registry had modules.
log = logging.getLogger(__package__)

CODE_LENGTH = 6
BIRTH_YEAR_MIN = 1900

SEXES = ("female", "male")
"""A patient's sex as the norms' regressions take it (app.norms; schema v8)."""
HANDEDNESS = ("right", "left")
"""A patient's dominant hand (schema v8): with `side`, whether the dominant arm is tested."""

MEASURED = {
    "body_mass_kg": (BODY_MASS_RANGE_KG, "kg", "Winter's segment proportions hold for adults"),
    "upper_arm_m": (UPPER_ARM_RANGE_M, "m", "shoulder to elbow of an adult"),
    "forearm_m": (FOREARM_RANGE_M, "m", "elbow to wrist of an adult"),
    "shoulder_m": (POSITION_RANGE_M, "m", ""),  # each of x and y, in the robot frame
}
"""A patient's measurements: their range (SI), its unit and what bounds it; the registry
refuses a value outside in SI, the window in the unit it shows (app.records.typed)."""
CHOSEN = {"side": (SIDES, "the affected side"), "sex": (SEXES, "not recorded"),
          "handedness": (HANDEDNESS, "the dominant hand")}
"""A patient's fields that take one of a few words: the words, and what the field says."""

_PATIENT_COLUMNS = ("code", "first_name", "last_name", "birth_year", "side", "body_mass_kg",
                    "upper_arm_m", "forearm_m", "shoulder_x_m", "shoulder_y_m", "notes",
                    "created_at", "sex", "handedness")
_CHANGEABLE = {"first_name", "last_name", "birth_year", "side", "body_mass_kg", "upper_arm_m",
               "forearm_m", "shoulder_m", "notes", "sex", "handedness"}


@dataclass(frozen=True, slots=True)
class Patient:
    """A patient as the clinic registered them. `code` is the only identifier
    that leaves the registry; names may be None (a study may keep none)."""

    code: str
    first_name: str | None
    last_name: str | None
    birth_year: int | None
    side: str | None
    body_mass_kg: float | None
    upper_arm_m: float | None
    forearm_m: float | None
    shoulder_m: tuple[float, float] | None
    notes: str
    created_at: datetime.datetime
    sex: str | None = None
    """"female" or "male" (SEXES), None when not recorded (patients before schema v8)."""
    handedness: str | None = None
    """The dominant hand, "right" or "left" (HANDEDNESS); None when not recorded."""

    @property
    def display_name(self) -> str:
        """'Last, First' for the window; the code when no name was entered."""
        names = [n for n in (self.last_name, self.first_name) if n]
        return ", ".join(names) if names else self.code

    def trial_overrides(self) -> dict:
        """The TrialParameters fields this patient defines, for
        `TrialParameters.replace(**patient.trial_overrides())`."""
        values = {
            "side": self.side,
            "body_mass_kg": self.body_mass_kg,
            "upper_arm_m": self.upper_arm_m,
            "forearm_m": self.forearm_m,
            "shoulder_m": self.shoulder_m,
        }
        return {k: v for k, v in values.items() if v is not None}


class Patients(Database):
    """Registering, changing and finding patients."""

    def create_patient(
        self,
        first_name: str | None = None,
        last_name: str | None = None,
        *,
        birth_year: int | None = None,
        side: str | None = None,
        body_mass_kg: float | None = None,
        upper_arm_m: float | None = None,
        forearm_m: float | None = None,
        shoulder_m: tuple[float, float] | None = None,
        notes: str = "",
        sex: str | None = None,
        handedness: str | None = None,
    ) -> Patient:
        """Register a patient and give them a new pseudonymous code. Two patients may
        share a name: look for an existing one first (`find_patients`)."""
        values = _patient_values(
            first_name=first_name, last_name=last_name, birth_year=birth_year, side=side,
            body_mass_kg=body_mass_kg, upper_arm_m=upper_arm_m, forearm_m=forearm_m,
            shoulder_m=shoulder_m, notes=notes, sex=sex, handedness=handedness,
        )
        values["created_at"] = utc_text(utc_now())
        with self._write() as conn:
            for _ in range(20):
                code = new_code()
                if not execute(conn, "SELECT 1 FROM patients WHERE code = ?",
                                     (code,)).fetchone():
                    break
            else:  # pragma: no cover - 20 collisions in 10⁹ codes
                raise RegistryError("could not draw an unused patient code; try again")
            values["code"] = code
            columns = ", ".join(values)
            marks = ", ".join("?" * len(values))
            execute(conn, f"INSERT INTO patients ({columns}) VALUES ({marks})",
                          tuple(values.values()))
            patient = patient_by_code(conn, self.where, code)
        log.info("patient %s registered", code)
        return patient

    def update_patient(self, code: str, /, **changes) -> Patient:
        """Change any of create_patient's fields; the code and creation time stay."""
        unknown = sorted(set(changes) - _CHANGEABLE)
        if unknown:
            raise InvalidRecordError(
                f"patient field(s) {', '.join(unknown)} cannot be changed; give any of "
                f"{', '.join(sorted(_CHANGEABLE))}"
            )
        with self._write() as conn:
            current = patient_by_code(conn, self.where, code)
            merged = {name: getattr(current, name) for name in _CHANGEABLE} | changes
            values = _patient_values(**merged)
            assignments = ", ".join(f"{name} = ?" for name in values)
            execute(conn, f"UPDATE patients SET {assignments} WHERE code = ?",
                          (*values.values(), code))
            patient = patient_by_code(conn, self.where, code)
        log.info("patient %s updated (%s)", code, ", ".join(sorted(changes)))
        return patient

    def patient(self, code: str) -> Patient:
        with self._read() as conn:
            return patient_by_code(conn, self.where, code)

    def patients(self) -> list[Patient]:
        """Every patient, by last name, first name, then code."""
        with self._read() as conn:
            rows = execute(conn, f"SELECT {', '.join(_PATIENT_COLUMNS)} FROM patients").fetchall()
        return sorted((_patient_from_row(r) for r in rows), key=_patient_order)

    def find_patients(self, first_name: str, last_name: str) -> list[Patient]:
        """Patients with exactly this name, ignoring case and accents: what the
        registration tab checks before creating a patient."""
        first, last = _fold(first_name), _fold(last_name)
        return [p for p in self.patients()
                if _fold(p.first_name) == first and _fold(p.last_name) == last]

    def search_patients(self, text: str, limit: int | None = 50) -> list[Patient]:
        """Patients whose code starts with `text`, or whose first or last name
        contains every word of it (ignoring case and accents)."""
        words = _fold(text).split()
        if not words:
            found = self.patients()
        else:
            prefix = text.strip().upper()
            found = [
                p for p in self.patients()
                if p.code.startswith(prefix)
                or all(w in _fold(p.first_name) or w in _fold(p.last_name) for w in words)
            ]
        return found if limit is None else found[:limit]


# -- lookups the other tables share ---------------------------------------------------
def patient_by_code(conn: sa.Connection, registry: Path | str, code: str) -> Patient:
    """The patient with this code; PatientNotFound naming the registry file if none."""
    row = execute(conn, f"SELECT {', '.join(_PATIENT_COLUMNS)} FROM patients WHERE code = ?",
                        (code,)).fetchone()
    if row is None:
        raise PatientNotFound(
            f"no patient has the code {code!r} in the registry {registry}; search by "
            "name or code to find the right one"
        )
    return _patient_from_row(row)


def patient_id(conn: sa.Connection, registry: Path | str, code: str, *,
               lock: bool = False) -> int:
    """The row id of the patient with this code (PatientNotFound if none). `lock`: the
    transaction is about to number a session or trial of theirs, or to change what it
    read of them, so on the server the patient's row is locked as the server's numbering
    locks it (postgres/numbering.py): stations writing for one patient take turns, and
    the next number read is the one inserted. (SQLite's BEGIN IMMEDIATE already lets one
    writer in at a time.)"""
    held = " FOR NO KEY UPDATE" if lock else ""
    row = execute(conn, "SELECT id FROM patients WHERE code = ?" + held, (code,)).fetchone()
    if row is None:
        patient_by_code(conn, registry, code)  # raises PatientNotFound with its message
    return row[0]


def new_code() -> str:
    """A fresh pseudonymous code: 'P' and 6 random Crockford base32 characters."""
    return "P" + "".join(secrets.choice(CODE_ALPHABET) for _ in range(CODE_LENGTH))


def is_code(code: object) -> bool:
    return isinstance(code, str) and CODE_PATTERN.fullmatch(code) is not None


# -- values ------------------------------------------------------------------------------
def _fold(text: str | None) -> str:
    """Case- and accent-free form for matching names typed differently."""
    if not text:
        return ""
    decomposed = unicodedata.normalize("NFKD", text.casefold())
    return "".join(c for c in decomposed if not unicodedata.combining(c)).strip()


def _patient_order(patient: Patient) -> tuple:
    return (_fold(patient.last_name), _fold(patient.first_name), patient.code)


def _optional_name(name: str, value: object) -> str | None:
    if value is None:
        return None
    return checked_text(name, value, NAME_MAX_CHARS) or None


def _optional_range(name: str, value: object, low: float, high: float, unit: str,
                    why: str = "") -> float | None:
    if value is None:
        return None
    try:
        return check_range(name, value, low, high, unit, why)
    except CoreError as exc:
        raise InvalidRecordError(str(exc)) from None


def birth_years() -> tuple[int, int]:
    """The years of birth the registry takes: from BIRTH_YEAR_MIN to this year."""
    return BIRTH_YEAR_MIN, datetime.date.today().year


def _measured(name: str, value: object, part: str = "") -> float | None:
    (low, high), unit, why = MEASURED[name]
    return _optional_range(name + part, value, low, high, unit, why)


def _patient_values(*, first_name, last_name, birth_year, side, body_mass_kg, upper_arm_m,
                    forearm_m, shoulder_m, notes, sex=None, handedness=None) -> dict:
    first, last = birth_years()
    if birth_year is not None and (
        isinstance(birth_year, bool) or not isinstance(birth_year, int)
        or not first <= birth_year <= last
    ):
        raise InvalidRecordError(
            f"birth_year = {birth_year!r} is not allowed; give a year {first}-{last}, or None"
        )
    for name, value in (("side", side), ("sex", sex), ("handedness", handedness)):
        words, meaning = CHOSEN[name]
        if value is not None and value not in words:
            raise InvalidRecordError(f"{name} = {value!r}: give one of {', '.join(words)}, "
                                     f"or None ({meaning})")
    if shoulder_m is None:
        shoulder = (None, None)
    else:
        try:
            x, y = shoulder_m
        except (TypeError, ValueError):
            raise InvalidRecordError(
                f"shoulder_m = {shoulder_m!r}: give a pair (x, y) in m in the robot frame"
            ) from None
        shoulder = (_measured("shoulder_m", x, "[x]"), _measured("shoulder_m", y, "[y]"))
    return {
        "first_name": _optional_name("first_name", first_name),
        "last_name": _optional_name("last_name", last_name),
        "birth_year": birth_year,
        "side": side,
        "body_mass_kg": _measured("body_mass_kg", body_mass_kg),
        "upper_arm_m": _measured("upper_arm_m", upper_arm_m),
        "forearm_m": _measured("forearm_m", forearm_m),
        "shoulder_x_m": shoulder[0],
        "shoulder_y_m": shoulder[1],
        "notes": checked_text("notes", notes if notes is not None else "", TEXT_MAX_CHARS),
        "sex": sex,
        "handedness": handedness,
    }


def _patient_from_row(row: tuple) -> Patient:
    (code, first, last, birth_year, side, mass, upper, fore, sx, sy, notes, created, sex,
     handedness) = row
    shoulder = None if sx is None or sy is None else (sx, sy)
    return Patient(code, first, last, birth_year, side, mass, upper, fore, shoulder, notes,
                   datetime.datetime.fromisoformat(created), sex, handedness)
