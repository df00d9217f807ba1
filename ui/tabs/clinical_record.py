"""The Registration tab's clinical record of the chosen patient (schema v8, issue 31): a
session's clinical scales, a note on the session or one of its trials, a trial of it
marked invalid or valid again, and a correction of the patient's recorded fields, each
saying who records it (the registry adds when). What the registry refuses is shown in one
line under the box; nothing is stored then. The scores are typed as on the command line
(app.records.typed): a total, or KEY=VALUE scores.
"""

from __future__ import annotations

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
from app.records.scales import SCALE_LABELS, SCALES
from app.records.store import RecordStore
from app.records.typed import typed_scores, typed_value
from ui import theme
from ui.fields import ComboBox, SpinBox

MAX_NUMBER = 999_999
SCORE_HINT = {
    "fugl_meyer": "total 0-66, or A= B= C= D= (0-36, 0-10, 0-14, 0-6)",
    "arat": "total 0-57, or grasp= grip= pinch= gross=",
    "ashworth": "GROUP=GRADE, e.g. elbow_flexors=1+ wrist_flexors=2",
    "pain": "0-10",
    "fatigue": "0-10",
}


class ClinicalRecord(QGroupBox):
    """Signals: recorded(str): what was kept, in words (after any of the four)."""

    recorded = Signal(str)

    def __init__(self, registry: RecordStore | None = None, parent=None) -> None:
        super().__init__("Clinical record", parent)
        self.registry = registry
        self._patient: Patient | None = None
        self.by = QLineEdit()
        self.by.setPlaceholderText("the therapist's name")
        self.by.setAccessibleName("Recorded by")
        self.session = SpinBox()
        self.session.setRange(1, MAX_NUMBER)
        self.session.setAccessibleName("Session of the record")
        self.session.valueChanged.connect(lambda _: self._fill_trials())

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

        self.field = ComboBox()
        for name in CORRECTABLE:
            self.field.addItem(name, name)
        self.value = QLineEdit()
        self.value.setPlaceholderText("new value (SI: kg, m; shoulder X,Y; none)")
        self.value.setAccessibleName("Corrected value")
        self.correct_reason = QLineEdit()
        self.correct_reason.setPlaceholderText("why")
        self.correct_button = QPushButton("Correct")
        self.correct_button.clicked.connect(self.correct)
        correct_row = QHBoxLayout()
        correct_row.addWidget(self.field)
        correct_row.addWidget(self.value, 1)
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
        self._hint()
        self.set_patient(None)

    # -- public -------------------------------------------------------------------
    def set_registry(self, registry: RecordStore) -> None:
        self.registry = registry

    def hold(self) -> None:
        """Another patient is being chosen (their record read on the job thread): greyed
        until `set_patient` shows theirs."""
        self.setEnabled(False)
        self.outcome.setText("")

    def set_patient(self, patient: Patient | None, session: int | None = None,
                    items: list[tuple[str, int]] | None = None) -> None:
        """The patient whose record this is (None: nobody, and the record hidden), on
        `session` (the latest when None, read here); `items`: that session's
        `trial_items` when read already (on the job thread)."""
        self._patient = patient
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
        def do():
            scale = self.scale.currentData()
            entry = self.registry.record_scale(
                self._patient.code, self.session.value(), scale, rater=self.by.text(),
                **typed_scores(scale, self.scores.text().split()))
            self.scores.clear()
            total = "" if entry.total is None else f" {entry.total}"
            return f"{SCALE_LABELS[scale]}{total} kept for session {entry.session_number}."
        self._act(do)

    def add_note(self) -> None:
        def do():
            trial_id = self.trial.currentData() if self.note_on_trial.isChecked() else None
            if self.note_on_trial.isChecked() and trial_id is None:
                raise RegistryError(f"session {self.session.value()} has no finished trial "
                                    "to write the note on")
            note = self.registry.add_note(self._patient.code, self.session.value(),
                                          self.note.text(), author=self.by.text(),
                                          trial_id=trial_id)
            self.note.clear()
            where = (f"trial {self.trial.currentText()} of session {note.session_number}"
                     if trial_id else f"session {note.session_number}")
            return f"Note kept for {where}."
        self._act(do)

    def mark(self, valid: bool) -> None:
        def do():
            trial_id = self.trial.currentData()
            if trial_id is None:
                raise RegistryError(f"session {self.session.value()} has no finished trial "
                                    "to mark")
            mark = self.registry.mark_trial(trial_id, valid=valid,
                                            reason=self.mark_reason.text(), by=self.by.text())
            self.mark_reason.clear()
            self._fill_trials()  # its "(invalid)", the same trial kept chosen
            number = self.trial.currentText().split()[0]
            return (f"Trial {number} marked "
                    f"{'valid again' if mark.valid else 'invalid'}: {mark.reason}.")
        self._act(do)

    def correct(self) -> None:
        def do():
            field = self.field.currentData()
            patient = self.registry.correct_patient(
                self._patient.code, field, typed_value(field, self.value.text()),
                reason=self.correct_reason.text(), by=self.by.text())
            self._patient = patient
            last = self.registry.corrections(patient.code)[-1]
            self.value.clear()
            self.correct_reason.clear()
            return (f"{field} corrected: {last.old_value!r} → {last.new_value!r} (kept with "
                    "why, who and when).")
        self._act(do)

    def refresh_trials(self, read: tuple[str, int, list[tuple[str, int]]] | None = None
                       ) -> None:
        """The session's finished trials again (after a trial ended: the list was filled
        when the patient was chosen, so the trials run since could not be marked, and a
        note on one was refused as "no finished trial"). `read`: (patient code, session,
        `trial_items`) read on the window's job thread, shown when still of the record's
        patient and session (else read again here)."""
        if read is not None and self._patient is not None \
                and read[:2] == (self._patient.code, self.session.value()):
            self._fill_trials(read[2])
        else:
            self._fill_trials()

    def shown_session(self) -> tuple[str, int] | None:
        """(patient code, session) whose trials the record lists; None when nobody."""
        return None if self._patient is None else (self._patient.code, self.session.value())

    @property
    def patient(self) -> Patient | None:
        """The patient as corrected last."""
        return self._patient

    # -- helpers --------------------------------------------------------------------
    def _act(self, do) -> None:
        if self._patient is None or self.registry is None:
            return
        try:
            said = do()
        except RegistryError as exc:
            self.outcome.setText(f"{theme.PROBLEM_SIGN} {exc}")
            return
        self.outcome.setText(said)
        self.recorded.emit(said)

    def _hint(self) -> None:
        self.scores.setPlaceholderText(SCORE_HINT[self.scale.currentData()])

    def _fill_trials(self, items: list[tuple[str, int]] | None = None) -> None:
        """The session's finished trials (`items` when read already), the one chosen before
        kept chosen (refilling chose the first: "Trial 1 marked invalid" was said when
        trial 3 was marked)."""
        chosen = self.trial.currentData()
        self.trial.clear()
        if self._patient is None or self.registry is None:
            return
        if items is None:
            items = trial_items(self.registry, self._patient.code, self.session.value())
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
