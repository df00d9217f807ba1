"""The Registration tab's New patient form (a part of ui.tabs.registration.RegistrationTab):
the patient's name, year of birth and side, the norms' covariates (sex, handedness) and the
measurements the arm model needs, each optional; registered on the window's job thread
(ui.jobs: "Saving…"), a namesake named for the therapist to acknowledge first.
"""

from __future__ import annotations

import datetime

from PySide6.QtWidgets import (
    QCheckBox,
    QDoubleSpinBox,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
)

from app.records.registry import BIRTH_YEAR_MIN, Patient
from app.units import CM_PER_M as CM
from core.arm import BODY_MASS_RANGE_KG, FOREARM_RANGE_M, UPPER_ARM_RANGE_M
from core.trial import POSITION_RANGE_M
from ui.fields import ComboBox, DoubleSpinBox, SpinBox, commit_all
from ui.tabs.patient_words import describe

NOT_MEASURED = "not measured"
CREATE = "Register new patient"


def _optional_spin(low: float, high: float, decimals: int, suffix: str,
                   step: float) -> QDoubleSpinBox:
    """A spin box whose lowest value reads 'not measured' (and means None)."""
    box = DoubleSpinBox()
    box.setDecimals(decimals)
    box.setRange(low - step, high)
    box.setSingleStep(step)
    box.setSuffix(suffix)
    box.setSpecialValueText(NOT_MEASURED)
    box.setValue(box.minimum())
    return box


def _optional_value(box: QDoubleSpinBox, scale: float = 1.0) -> float | None:
    return None if box.value() == box.minimum() else box.value() / scale


class NewPatient:
    """Register new patient (a part of RegistrationTab)."""

    def _new_patient_form(self) -> QGroupBox:
        """The form's fields (attributes of the tab) in their box."""
        self.first_name = QLineEdit()
        self.last_name = QLineEdit()
        self.birth_year = SpinBox()
        self.birth_year.setRange(BIRTH_YEAR_MIN - 1, datetime.date.today().year)
        self.birth_year.setSpecialValueText("not given")
        self.birth_year.setValue(self.birth_year.minimum())
        self.side = ComboBox()
        for text, value in (("Right arm", "right"), ("Left arm", "left"), ("Not given", None)):
            self.side.addItem(text, value)
        # the norms' covariates (app.norms): the age comes from the year of birth
        self.sex = ComboBox()
        for text, value in (("Not given", None), ("Female", "female"), ("Male", "male")):
            self.sex.addItem(text, value)
        self.handedness = ComboBox()
        for text, value in (("Not given", None), ("Right-handed", "right"),
                            ("Left-handed", "left")):
            self.handedness.addItem(text, value)
        self.body_mass = _optional_spin(*BODY_MASS_RANGE_KG, 1, " kg", 1.0)
        self.upper_arm = _optional_spin(*(v * CM for v in UPPER_ARM_RANGE_M), 2, " cm", 0.5)
        self.forearm = _optional_spin(*(v * CM for v in FOREARM_RANGE_M), 2, " cm", 0.5)
        pos_lo, pos_hi = (v * CM for v in POSITION_RANGE_M)
        self.shoulder_x = _optional_spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.shoulder_y = _optional_spin(pos_lo, pos_hi, 2, " cm", 1.0)
        self.shoulder_x.setAccessibleName("Shoulder x")
        self.shoulder_y.setAccessibleName("Shoulder y")
        self.same_name = QCheckBox("A different person with the same name")
        self.same_name.hide()
        self.create_button = QPushButton(CREATE)
        self.create_button.clicked.connect(self.create_patient)
        self.create_problem = self._problem_label()
        new = QGroupBox("New patient")
        form = QFormLayout(new)
        form.addRow("First name", self.first_name)
        form.addRow("Last name", self.last_name)
        form.addRow("Year of birth", self.birth_year)
        form.addRow("Side trained", self.side)
        form.addRow("Sex", self.sex)
        form.addRow("Handedness", self.handedness)
        form.addRow("Body mass", self.body_mass)
        form.addRow("Upper arm", self.upper_arm)
        form.addRow("Forearm", self.forearm)
        shoulder = QHBoxLayout()
        shoulder.addWidget(QLabel("x"))
        shoulder.addWidget(self.shoulder_x, 1)
        shoulder.addWidget(QLabel("y"))
        shoulder.addWidget(self.shoulder_y, 1)
        form.addRow("Shoulder", shoulder)
        form.addRow(self.same_name)
        form.addRow(self.create_button)
        form.addRow(self.create_problem)
        return new

    def create_patient(self) -> None:
        """Register the patient the form shows, on the job thread (the button says
        "Saving…"): a namesake not acknowledged is named instead (`_created`); the patient
        registered is then chosen, unless another was chosen while it was saved."""
        self.create_problem.hide()
        if "create" in self._asked:
            return
        if self.registry is None:
            self._show(self.create_problem, "No registry is open.")
            return
        first = self.first_name.text().strip() or None
        last = self.last_name.text().strip() or None
        if first is None and last is None:
            self._show(self.create_problem, "Give the patient's first or last name. (A study "
                       "that keeps no names can register by code from the command line.)")
            return
        # a number still typed counts; one refused (out of range, not a number) stops the
        # registration once, so the field's old value is not registered unseen
        refused = commit_all((self.birth_year, self.body_mass, self.upper_arm, self.forearm,
                              self.shoulder_x, self.shoulder_y))
        if refused:
            self._show(self.create_problem, f"Not registered. {refused[0]}")
            return
        shoulder = (_optional_value(self.shoulder_x, CM), _optional_value(self.shoulder_y, CM))
        fields = dict(
            birth_year=(None if self.birth_year.value() == self.birth_year.minimum()
                        else self.birth_year.value()),
            side=self.side.currentData(),
            body_mass_kg=_optional_value(self.body_mass),
            upper_arm_m=_optional_value(self.upper_arm, CM),
            forearm_m=_optional_value(self.forearm, CM),
            shoulder_m=None if None in shoulder else shoulder,
            sex=self.sex.currentData(), handedness=self.handedness.currentData(),
        )
        registry, namesakes_said = self.registry, self.same_name.isChecked()

        def save() -> Patient | list[Patient] | Exception:
            try:
                if not namesakes_said:
                    namesakes = registry.find_patients(first or "", last or "")
                    if namesakes:
                        return namesakes
                return registry.create_patient(first, last, **fields)
            except Exception as exc:  # RegistryError, a station's fault: said as is
                return exc

        choices = self._choices
        self._ask("create", save, lambda saved: self._created(saved, first, last, choices))

    def _created(self, saved: Patient | list[Patient] | Exception, first: str | None,
                 last: str | None, choices: int) -> None:
        """The registry's answer to Register new patient: the patient registered (chosen
        if nobody was chosen since the click, `choices`), the namesakes to acknowledge, or
        the refusal."""
        if isinstance(saved, Exception):
            self._show(self.create_problem, str(saved))
            return
        if isinstance(saved, list):
            self.same_name.show()
            codes = "; ".join(describe(p) for p in saved)
            self._show(self.create_problem,
                       f"Already registered: {codes}. Choose them from the list, or tick "
                       f"'{self.same_name.text()}' to register someone new.")
            self.search_field.setText(" ".join(n for n in (first, last) if n))
            self.search()
            return
        self._clear_new()
        if choices != self._choices:
            self.search()  # listed; the patient chosen meanwhile stays chosen
            return
        self.search_field.blockSignals(True)
        self.search_field.setText(saved.code)
        self.search_field.blockSignals(False)
        self.choose(saved)
        self.search()
        # the new patient's name and stored measurements, at the top of the forms
        self.bring_into_view(self.measurements_label)
        self.bring_into_view(self.patient_label)

    def _clear_new(self) -> None:
        for edit in (self.first_name, self.last_name):
            edit.clear()
        for box in (self.birth_year, self.body_mass, self.upper_arm, self.forearm,
                    self.shoulder_x, self.shoulder_y):
            box.setValue(box.minimum())
        for choice in (self.sex, self.handedness):
            choice.setCurrentIndex(0)
        self.same_name.setChecked(False)
        self.same_name.hide()
        self.create_problem.hide()
