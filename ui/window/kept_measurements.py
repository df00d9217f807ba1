"""The measurements a patient's record lacked, given on the Parameters tab, kept in the
record (a part of MainWindow).

Why: a patient registered without their body mass, arm lengths or shoulder position was
refused on the Parameters tab until the values were typed or "Use these values for this
patient" was pressed; the trial then ran with them and the record still had none, so the
same refusal came back the next time, and the registry, the report and the exports could
not say what the patient measures. Now the tab asks for them to be kept (keep_asked), and
they are written here, on the job thread, through the registry's audited correction
(Registry.correct_patient: the old value, none, the new one, why, who and when; no trial
file is touched). The Registration tab then shows them stored, and the Parameters tab,
given the patient's record as it is now, takes them as the patient's.
"""

from __future__ import annotations

import logging

from app.records.registry import Patient
from app.records.typed import FIELD_NAMES, shown_value

log = logging.getLogger(__name__)


class KeptMeasurements:
    """MainWindow's part that keeps the Parameters tab's values in the patient's record."""

    def _connect_kept_measurements(self) -> None:
        self.parameters_tab.keep_asked.connect(self.keep_measurements)
        # one name for who records, on the tab where the therapist gave it
        checked_by, recorded_by = self.parameters_tab.checked_by, self.registration_tab.clinical.by
        checked_by.textEdited.connect(recorded_by.setText)
        recorded_by.textEdited.connect(checked_by.setText)

    def keep_measurements(self, code: str, values: dict, by: str) -> None:
        """Keep `values` ({field: (SI value, reason)}) in patient `code`'s record, one
        audited correction each; what was kept is shown as the patient's record, what was
        refused said in one line."""
        registry = self.registry

        def save() -> tuple[Patient | None, Exception | None]:
            patient = None
            try:
                for field, (value, reason) in values.items():
                    patient = registry.correct_patient(code, field, value, reason=reason,
                                                       by=by)
            except Exception as exc:  # the registry's refusal, a station's fault: said
                return patient, exc
            return patient, None

        def saved(answer: tuple[Patient | None, Exception | None]) -> None:
            patient, refused = answer
            current = self.patient is not None and self.patient.code == code
            # a refusal for a patient chosen before is said on the message line only
            self.parameters_tab.keep_answered(str(refused) if refused and current else "")
            if patient is not None and current:
                # shown as the record is now; the Parameters tab follows (patient_selected)
                self.registration_tab.show_changed(patient)
            if refused is not None:
                log.error("the measurements of %s could not be kept", code, exc_info=refused)
                self._say(f"{code}'s measurements were not kept in their record: {refused}",
                          problem=True)
                return
            words = ", ".join(f"{FIELD_NAMES[field].lower()} {shown_value(field, value)}"
                              for field, (value, _why) in values.items())
            self._say(f"Kept in {code}'s record, checked by {by}: {words}.")

        self.jobs.run(save, saved)
