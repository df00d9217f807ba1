"""The Registration tab's clinical record of the chosen patient (schema v8, issue 31): a
session's clinical scales, a note on the session or one of its trials, a trial of it
marked invalid or valid again, and a correction of the patient's recorded fields, each
saying who records it (the registry adds when). What the registry refuses is shown in one
line under the box; nothing is stored then. The scores are typed as on the command line
(app.records.typed): a total, or KEY=VALUE scores.

Each action, and each read that refreshes the record (a session's trials), asks the registry
on the window's job thread (ui.jobs): on a station whose network went silent each call may
wait the registry's bounded wait (app.records.registry.postgres.deadline, 5 s), the window
frozen meanwhile. What is recorded is what the fields showed at the click; the button says
"Saving…" and the record's buttons wait; the outcome line says what the registry kept only
once it said so, and an answer for a patient no longer shown is not shown.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QLineEdit,
    QPushButton,
)

from app.errors import RegistryError
from app.records.registry import CORRECTABLE, Patient
from app.records.registry.patients import CHOSEN
from app.records.scales import SCALE_LABELS, SCALES
from app.records.store import RecordStore
from app.records.typed import FIELD_NAMES, shown_value, typed_scores, typed_shown_value
from app.units import MEASUREMENT_UNITS
from ui import theme
from ui.fields import ComboBox, SpinBox
from ui.jobs import Jobs

MAX_NUMBER = 999_999
SAVING = "Saving…"
SCORE_HINT = {
    "fugl_meyer": "total 0-66, or A= B= C= D= (0-36, 0-10, 0-14, 0-6)",
    "arat": "total 0-57, or grasp= grip= pinch= gross=",
    "ashworth": "GROUP=GRADE, e.g. elbow_flexors=1+ wrist_flexors=2",
    "pain": "0-10",
    "fatigue": "0-10",
}

VALUE_HINT = {"birth_year": "a year, e.g. 1961", "shoulder_m": "x,y in cm, e.g. -12,73",
              **{name: " or ".join(words) for name, (words, _) in CHOSEN.items()},
              **{name: f"in {unit}" for name, (unit, _) in MEASUREMENT_UNITS.items()
                 if name != "shoulder_m"}}
"""What the Correct row's value takes, per field (the units the Registration tab shows)."""


class ClinicalRecord(QGroupBox):
    """Signals: recorded(str): what was kept, in words (after any of the four);
    said(str, bool): that, or the registry's refusal (problem True), for the window's
    message line: the outcome line under the record is below the fold of the Registration
    tab on a laptop, and a refused scale was said nowhere the therapist looked."""

    recorded = Signal(str)
    said = Signal(str, bool)

    def __init__(self, registry: RecordStore | None = None, parent=None, *,
                 jobs: Jobs | None = None) -> None:
        super().__init__("Clinical record", parent)
        self.registry = registry
        # the window's job thread (one registry call after another); a record on its own
        # has its own
        self.jobs = jobs if jobs is not None else Jobs(self)
        self._patient: Patient | None = None
        self._saving: object | None = None  # the action waiting for the registry: its token
        self._listing: object | None = None  # the trials being read: their token
        self.by = QLineEdit()
        self.by.setPlaceholderText("the therapist's name")
        self.by.setAccessibleName("Recorded by")
        self.session = SpinBox()
        self.session.setRange(1, MAX_NUMBER)
        self.session.setAccessibleName("Session of the record")
        self.session.valueChanged.connect(lambda _: self._list_trials())

        self.scale = ComboBox()
        for scale in SCALES:
            self.scale.addItem(SCALE_LABELS[scale], scale)
        self.scale.currentIndexChanged.connect(self._hint)
        self.scores = QLineEdit()
        self.scores.setAccessibleName("Scores")
        self.record_scale_button = QPushButton("Record scale")
        self.record_scale_button.clicked.connect(self.record_scale)
        scale_row = QHBoxLayout()
        scale_row.addWidget(self.scale)
        scale_row.addWidget(self.scores, 1)
        scale_row.addWidget(self.record_scale_button)

        self.note = QLineEdit()
        self.note.setPlaceholderText("a note on this session")
        self.note.setAccessibleName("Note")
        self.note_on_trial = QCheckBox("on the trial below")
        self.note_on_trial.setToolTip("The note is on the trial chosen under it, not on the "
                                      "whole session")
        self.note_button = QPushButton("Add note")
        self.note_button.clicked.connect(self.add_note)
        note_row = QHBoxLayout()
        note_row.addWidget(self.note, 1)
        note_row.addWidget(self.note_on_trial)
        note_row.addWidget(self.note_button)

        self.trial = ComboBox()
        self.trial.setAccessibleName("Trial to mark")
        self.mark_reason = QLineEdit()
        self.mark_reason.setPlaceholderText("why")
        self.invalid_button = QPushButton("Mark invalid")
        self.invalid_button.clicked.connect(lambda: self.mark(False))
        self.valid_button = QPushButton("Valid again")
        self.valid_button.clicked.connect(lambda: self.mark(True))
        mark_row = QHBoxLayout()
        mark_row.addWidget(self.trial)
        mark_row.addWidget(self.mark_reason, 1)
        mark_row.addWidget(self.invalid_button)
        mark_row.addWidget(self.valid_button)

        # the fields by the Registration tab's names, in its units (app.units: cm)
        self.field = ComboBox()
        for name in (name for name in FIELD_NAMES if name in CORRECTABLE):  # its order
            unit = MEASUREMENT_UNITS.get(name, ("",))[0]
            self.field.addItem(f"{FIELD_NAMES[name]}{f' ({unit})' if unit else ''}", name)
        self.field.currentIndexChanged.connect(self._value_hint)
        self.value = QLineEdit()
        self.value.setAccessibleName("Corrected value")
        self.correct_reason = QLineEdit()
        self.correct_reason.setPlaceholderText("why")
        self.correct_button = QPushButton("Correct")
        self.correct_button.clicked.connect(self.correct)
        correct_row = QHBoxLayout()
        correct_row.addWidget(self.field)
        correct_row.addWidget(self.value, 2)
        correct_row.addWidget(self.correct_reason, 1)
        correct_row.addWidget(self.correct_button)

        self.outcome = theme.set_role(QLabel(""), "caption")
        self.outcome.setWordWrap(True)
        form = QFormLayout(self)
        form.addRow("Recorded by", self.by)
        form.addRow("Session", self.session)
        form.addRow("Scale", scale_row)
        form.addRow("Note", note_row)
        form.addRow("Trial", mark_row)
        form.addRow("Correct", correct_row)
        form.addRow(self.outcome)
        self._buttons = {self.record_scale_button: self.record_scale_button.text(),
                         self.note_button: self.note_button.text(),
                         self.invalid_button: self.invalid_button.text(),
                         self.valid_button: self.valid_button.text(),
                         self.correct_button: self.correct_button.text()}
        self._hint()
        self._value_hint()
        self.set_patient(None)

    # -- public -------------------------------------------------------------------
    def set_registry(self, registry: RecordStore) -> None:
        self.registry = registry

    def hold(self) -> None:
        """Another patient is being chosen (their record read on the job thread): greyed
        until `set_patient` shows theirs; answers for the patient before are not shown."""
        self.setEnabled(False)
        self.outcome.setText("")
        self.trial.clear()  # the patient before's trials
        self._drop_answers()

    def set_patient(self, patient: Patient | None, session: int | None = None,
                    items: list[tuple[str, int]] | None = None) -> None:
        """The patient whose record this is (None: nobody, and the record hidden), on
        `session` (the latest when None, read here); `items`: that session's
        `trial_items` when read already (on the job thread)."""
        self._patient = patient
        self._drop_answers()
        self.setEnabled(patient is not None and self.registry is not None)
        # Nobody chosen, the record has nothing to show: hidden, so that the New patient
        # form below it is in view for a first patient (from a fresh clone it was a scroll
        # away, under a greyed record).
        self.setHidden(patient is None)
        self.outcome.setText("")
        if patient is None or self.registry is None:
            return
        if session is None:
            sessions = [s.number for s in self.registry.sessions(patient.code)]
            session = sessions[-1] if sessions else 1
        self.session.blockSignals(True)
        self.session.setValue(session)
        self.session.blockSignals(False)
        self._fill_trials(items)

    def record_scale(self) -> None:
        registry, code, session = self.registry, self._code(), self.session.value()
        scale, text, rater = self.scale.currentData(), self.scores.text(), self.by.text()

        def save():
            return registry.record_scale(code, session, scale, rater=rater,
                                         **typed_scores(scale, text.split()))

        def kept(entry) -> str:
            self._clear_if(self.scores, text)
            total = "" if entry.total is None else f" {entry.total}"
            return f"{SCALE_LABELS[scale]}{total} kept for session {entry.session_number}."
        self._act(self.record_scale_button, save, kept)

    def add_note(self) -> None:
        registry, code, session = self.registry, self._code(), self.session.value()
        on_trial, text, author = self.note_on_trial.isChecked(), self.note.text(), self.by.text()
        trial_id = self.trial.currentData() if on_trial else None
        number = self.trial.currentText()

        def save():
            if on_trial and trial_id is None:
                raise RegistryError(f"session {session} has no finished trial to write the "
                                    "note on")
            return registry.add_note(code, session, text, author=author, trial_id=trial_id)

        def kept(note) -> str:
            self._clear_if(self.note, text)
            where = (f"trial {number} of session {note.session_number}"
                     if trial_id else f"session {note.session_number}")
            return f"Note kept for {where}."
        self._act(self.note_button, save, kept)

    def mark(self, valid: bool) -> None:
        registry, code, session = self.registry, self._code(), self.session.value()
        trial_id, reason, by = self.trial.currentData(), self.mark_reason.text(), self.by.text()
        number = self.trial.currentText().split()[0] if trial_id is not None else ""

        def save():
            if trial_id is None:
                raise RegistryError(f"session {session} has no finished trial to mark")
            mark = registry.mark_trial(trial_id, valid=valid, reason=reason, by=by)
            return mark, trial_items(registry, code, session)  # its "(invalid)" shown

        def kept(answer) -> str:
            mark, items = answer
            self._clear_if(self.mark_reason, reason)
            if self.session.value() == session:
                self._fill_trials(items)  # the same trial kept chosen
            return (f"Trial {number} marked "
                    f"{'valid again' if mark.valid else 'invalid'}: {mark.reason}.")
        button = self.valid_button if valid else self.invalid_button
        self._act(button, save, kept)

    def correct(self) -> None:
        registry, code, by = self.registry, self._code(), self.by.text()
        field, text, reason = (self.field.currentData(), self.value.text(),
                               self.correct_reason.text())

        def save():
            patient = registry.correct_patient(code, field, typed_shown_value(field, text),
                                               reason=reason, by=by)
            return patient, registry.corrections(code)[-1]

        def kept(answer) -> str:
            self._patient, last = answer
            self._clear_if(self.value, text)
            self._clear_if(self.correct_reason, reason)
            return (f"{FIELD_NAMES[field]} corrected: {shown_value(field, last.old_value)} → "
                    f"{shown_value(field, last.new_value)} (kept with why, who and when).")
        self._act(self.correct_button, save, kept)

    def refresh_trials(self, read: tuple[str, int, list[tuple[str, int]]] | None = None
                       ) -> None:
        """The session's finished trials again (after a trial ended: the list was filled
        when the patient was chosen, so the trials run since could not be marked, and a
        note on one was refused as "no finished trial"). `read`: (patient code, session,
        `trial_items`) read on the window's job thread, shown when still of the record's
        patient and session (else read again, on the job thread)."""
        if read is not None and self._patient is not None \
                and read[:2] == (self._patient.code, self.session.value()):
            self._listing = None  # newer than any list still being read
            self._fill_trials(read[2])
        else:
            self._list_trials()

    def shown_session(self) -> tuple[str, int] | None:
        """(patient code, session) whose trials the record lists; None when nobody."""
        return None if self._patient is None else (self._patient.code, self.session.value())

    @property
    def patient(self) -> Patient | None:
        """The patient as corrected last."""
        return self._patient

    def patient_changed(self, patient: Patient) -> None:
        """The record's patient's row changed elsewhere (the Parameters tab kept their
        measurements): this one is now theirs."""
        if self._patient is not None and patient.code == self._patient.code:
            self._patient = patient

    # -- helpers --------------------------------------------------------------------
    def _code(self) -> str | None:
        return None if self._patient is None else self._patient.code

    def _act(self, button: QPushButton, save: Callable[[], object],
             kept: Callable[[object], str]) -> None:
        """`save()` (the registry's write, and the reads that show it) on the job thread,
        `button` saying "Saving…" and the record's buttons waiting meanwhile; once
        answered for the patient still shown, `kept(answer)` says what was kept (the
        outcome line, `recorded`), or the registry's refusal is said in one line."""
        if self._patient is None or self.registry is None or self._saving is not None:
            return
        token = self._saving = object()

        def run() -> object:
            try:
                return save()
            except Exception as exc:  # RegistryError, a station's fault: said, not raised
                return exc

        def answered(answer: object) -> None:
            if self._saving is not token:
                return  # another patient shown since
            self._saving = None
            self._wait_buttons(None)
            if isinstance(answer, Exception):
                refusal = (str(answer) if isinstance(answer, RegistryError)
                           else f"Not kept: {answer}")
                self.outcome.setText(f"{theme.PROBLEM_SIGN} {refusal}")
                self.said.emit(f"Clinical record: {refusal}", True)
                return
            said = kept(answer)
            self.outcome.setText(said)
            self.recorded.emit(said)
            self.said.emit(f"Clinical record: {said}", False)

        self.outcome.setText("")
        self._wait_buttons(button)
        self.jobs.run(run, answered)

    def saving(self) -> bool:
        """An action waits for the registry's answer."""
        return self._saving is not None

    def _wait_buttons(self, saving: QPushButton | None) -> None:
        """The action buttons wait while `saving` (None: none) says "Saving…"."""
        for button, text in self._buttons.items():
            button.setEnabled(saving is None)
            button.setText(SAVING if button is saving else text)

    def _drop_answers(self) -> None:
        self._saving = self._listing = None
        self._wait_buttons(None)

    @staticmethod
    def _clear_if(field: QLineEdit, text: str) -> None:
        """`field` cleared once what it held at the click is kept (not what was typed
        since)."""
        if field.text() == text:
            field.clear()

    def _list_trials(self) -> None:
        """The session's finished trials read on the job thread, listed once read if the
        record still shows that patient and session."""
        self.trial.clear()
        if self._patient is None or self.registry is None:
            return
        registry, code, session = self.registry, self._patient.code, self.session.value()
        token = self._listing = object()

        def listed(items: list[tuple[str, int]]) -> None:
            if self._listing is token and self._code() == code and \
                    self.session.value() == session:
                self._listing = None
                self._fill_trials(items)

        self.jobs.run(lambda: trial_items(registry, code, session), listed)

    def _hint(self) -> None:
        self.scores.setPlaceholderText(SCORE_HINT[self.scale.currentData()])

    def _value_hint(self) -> None:
        hint = VALUE_HINT.get(self.field.currentData(), "the new value")
        self.value.setPlaceholderText(hint)
        self.value.setToolTip(f"{hint}; 'none' clears the field")

    def _fill_trials(self, items: list[tuple[str, int]] | None) -> None:
        """The session's finished trials as read (None: read on the job thread), the one
        chosen before kept chosen (refilling chose the first: "Trial 1 marked invalid"
        was said when trial 3 was marked)."""
        if items is None:
            self._list_trials()
            return
        chosen = self.trial.currentData()
        self.trial.clear()
        if self._patient is None or self.registry is None:
            return
        for label, trial_id in items:
            self.trial.addItem(label, trial_id)
        index = self.trial.findData(chosen)
        if index >= 0:
            self.trial.setCurrentIndex(index)


def trial_items(registry: RecordStore, code: str, session: int) -> list[tuple[str, int]]:
    """The finished trials of patient `code`'s session as the record lists them: (its
    number, marked "(invalid)" when its latest mark is, its id); none when the session
    cannot be read."""
    invalid = registry.invalid_trials(code)
    try:
        trials = registry.trials(code, session)
    except RegistryError:
        trials = []
    return [(f"{t.number}{' (invalid)' if t.id in invalid else ''}", t.id)
            for t in trials if t.finished]
