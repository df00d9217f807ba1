"""The Registration tab (thesis Fig. A.2): who the patient is, and which session and
trial this is.

Patients are found in the registry by a fragment of their name or their code, or
registered new with the measurements the arm model needs and the norms' covariates (sex,
handedness). The chosen patient's clinical record (ui.tabs.clinical_record): a session's
scales and notes, a trial marked invalid, a correction kept with its audit. The session and trial
numbers are filled in from the registry (the next trial of today's session, else
trial 1 of a new session) and stay editable; a trial number already used is
refused with the next free one named. Names stay in the registry: only the
pseudonymous code leaves this tab.

Choosing a patient, Confirm and registering a new patient ask the registry on the window's
job thread (ui.jobs), never on the window's: on a station whose network went silent each
call may wait the registry's bounded wait (app.records.registry.postgres.deadline, 5 s)
before the station answers from its standby, the window frozen meanwhile (no repaint, no
emergency-stop click). What was asked is taken at the click; the button says it waits
("Loading…", "Checking…", "Saving…"), and an answer for a choice no longer current
(another patient chosen meanwhile, a number edited, the window closed) is dropped, never
shown for the wrong patient. While a patient is loading nobody is confirmed: Start waits.
"""

from __future__ import annotations

from collections.abc import Callable

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QListWidgetItem,
    QPushButton,
    QVBoxLayout,
    QWidget,
)

from app.errors import RegistryError
from app.records.registry import Patient, Registration, Session
from app.records.store import RecordStore
from ui import plots, theme
from ui.fields import SpinBox, commit_all
from ui.jobs import Jobs
from ui.tabs.clinical_record import SAVING, ClinicalRecord
from ui.tabs.patient_words import describe, measurements, names_note
from ui.tabs.registration_find import PatientSearch
from ui.tabs.registration_new import CREATE, NewPatient
from ui.tabs.registration_numbers import (
    Numbers,
    gap_refusal,
    read_choice,
    read_numbers,
    session_trials,
    sessions_read,
)

LOADING = "Loading…"
CHECKING = "Checking…"
CONFIRM = "Use this patient and these numbers"
MAX_NUMBER = 999_999


class RegistrationTab(PatientSearch, NewPatient, QWidget):
    """Signals:
    patient_selected(Patient): a patient was chosen (their measurements can fill the
        Parameters tab: ParametersTab.apply_patient).
    registered(Patient, app.records.registry.Registration): the therapist confirmed the patient
        and the numbers for the next trial (begin_trial takes them at Start).
    unconfirmed(): the confirmed patient and numbers no longer hold (another patient
        chosen, a number edited, the registry refused them): the window's Start waits for
        Confirm again, so it never registers a trial under numbers or a patient the tab
        no longer shows.
    said(str, bool): what the clinical record kept or the registry refused (problem True),
        for the window's message line.
    choice_failed(Patient, str): the record of a patient chosen could not be read (the
        registry's words): whatever waited for them to be chosen says so.
    """

    patient_selected = Signal(object)
    registered = Signal(object, object)
    unconfirmed = Signal()
    said = Signal(str, bool)  # the clinical record's outcome, for the window's message line
    choice_failed = Signal(object, str)

    def __init__(self, registry: RecordStore | None = None, parent=None, *,
                 jobs: Jobs | None = None) -> None:
        super().__init__(parent)
        self.registry = registry
        # the window's job thread (one registry call after another, in the order asked);
        # a tab on its own has its own
        self.jobs = jobs if jobs is not None else Jobs(self)
        self._patient: Patient | None = None  # the patient shown, their record read
        self._choosing: Patient | None = None  # chosen, their record being read
        self._asked: dict[str, object] = {}  # what waits for the job thread: its token
        self._registration: Registration | None = None
        self._choices = 0  # patients chosen so far: a new patient saved is chosen unless
        # another was chosen while it was being saved
        find = self._find_box()
        new = self._new_patient_form()

        # This trial
        self.patient_label = theme.set_role(QLabel("No patient chosen"), "lead")
        self.patient_label.setWordWrap(True)
        self.measurements_label = QLabel("")
        self.measurements_label.setObjectName("patient_measurements")
        self.measurements_label.setWordWrap(True)
        self.session = SpinBox()
        self.session.setRange(1, MAX_NUMBER)
        self.session.setAccessibleName("Session number")
        self.session.valueChanged.connect(lambda _: self._session_edited())
        self.session_note = theme.set_role(QLabel(""), "caption")
        self.trial = SpinBox()
        self.trial.setRange(1, MAX_NUMBER)
        self.trial.setAccessibleName("Trial number")
        self.trial.valueChanged.connect(self._numbers_edited)
        self.trial_problem = self._problem_label()
        self.confirm = theme.set_role(QPushButton(CONFIRM),
                                      "primary")
        self.confirm.clicked.connect(lambda: self.confirm_registration())
        self.confirmed = theme.set_role(QLabel(""), "ok")
        self.confirmed.setWordWrap(True)
        trial_box = QGroupBox("This trial")
        form = QFormLayout(trial_box)
        form.addRow(self.patient_label)
        form.addRow(self.measurements_label)
        form.addRow("Session", self.session)
        form.addRow("", self.session_note)
        form.addRow("Trial", self.trial)
        form.addRow(self.trial_problem)
        form.addRow(self.confirm)
        form.addRow(self.confirmed)
        self.names_note = theme.set_role(QLabel(names_note(registry)), "caption")
        self.names_note.setWordWrap(True)
        form.addRow(self.names_note)

        forms = QWidget()
        right = QVBoxLayout(forms)
        right.setContentsMargins(0, 0, 0, 0)
        right.addWidget(trial_box)
        # the chosen patient's scales, notes, validity marks and corrections (schema v8)
        self.clinical = ClinicalRecord(registry, jobs=self.jobs)
        self.clinical.recorded.connect(self._recorded)
        self.clinical.said.connect(self.said)
        right.addWidget(self.clinical)
        right.addWidget(new)
        right.addStretch(1)
        # the two forms scroll rather than make the window taller than a laptop's screen
        self.forms_scroll = plots.vertical_scroll(forms, 0)
        layout = QHBoxLayout(self)
        layout.addWidget(find, 1)
        layout.addWidget(self.forms_scroll, 1)
        self._refresh_buttons()
        if registry is not None:
            self.search()

    def _problem_label(self) -> QLabel:
        label = theme.set_role(QLabel(""), "problem")
        label.setWordWrap(True)
        label.hide()
        return label

    # -- public -------------------------------------------------------------------
    def set_registry(self, registry: RecordStore) -> None:
        self.registry = registry
        self.names_note.setText(names_note(registry))
        self.clinical.set_registry(registry)
        self.search()

    def selected_patient(self) -> Patient | None:
        return self._patient

    def registration(self) -> Registration | None:
        """The confirmed patient code and numbers, or None before confirmation."""
        return self._registration

    def numbers_reader(self) -> Callable[[], Numbers] | None:
        """`refresh_numbers`'s reads as one call for the window's job thread (None when no
        patient is chosen): what it returns is shown by `refresh_numbers(numbers)`."""
        if self._patient is None or self.registry is None:
            return None
        registry, code, record = self.registry, self._patient.code, self.clinical.shown_session()
        return lambda: read_numbers(registry, code, record)

    def refresh_numbers(self, numbers: Numbers | None = None) -> None:
        """Fill in the registry's numbers again (after a trial was registered): `numbers`
        as read on the job thread (`numbers_reader`), else read here. Numbers read for a
        patient no longer chosen are not shown (choosing read the new one's)."""
        if self._patient is None or self.registry is None:
            return
        if numbers is None:
            numbers = self.numbers_reader()()
        elif numbers.code != self._patient.code:
            return
        was_confirmed = self._registration is not None
        suggestion = numbers.suggestion
        for box, value in ((self.session, suggestion.session_number),
                           (self.trial, suggestion.trial_number)):
            box.blockSignals(True)
            box.setValue(value)
            box.blockSignals(False)
        self._session_edited(numbers.sessions)
        # the clinical record's trials: the one just finished can be marked or noted
        self.clinical.refresh_trials(numbers.record)
        if was_confirmed:
            # the therapist confirmed this patient: the next trial takes the next number
            # at once, the one shown (Start used to keep the old one and be refused)
            self.confirm_registration(numbers)

    def refresh_count(self) -> None:
        """The session line ("continues the session of …, N trials so far") read again from
        the registry on the job thread, the numbers and any refusal under them left as they
        are: after a Start the registry refused (another station's trial in the session,
        say), the line kept the count from before it."""
        if self._patient is None or self.registry is None:
            return
        registry, code = self.registry, self._patient.code

        def show(sessions: dict[int, Session] | Exception) -> None:
            if isinstance(sessions, dict) and self._patient is not None \
                    and self._patient.code == code:
                self._say_session(sessions)  # a refusal to read: the line as it was
        self._ask("sessions", lambda: sessions_read(registry, code), show)

    def show_refusal(self, refusal: Exception | str) -> None:
        """Show the registry's refusal of the numbers (e.g. DuplicateNumberError raised by
        Registry.begin_trial at Start) under the trial number."""
        self._unconfirm()
        self._show(self.trial_problem, str(refusal))

    # -- choosing -----------------------------------------------------------------
    def choosing(self) -> Patient | None:
        """The patient chosen whose record is being read (None when none is)."""
        return self._choosing

    def waiting(self) -> bool:
        """The tab waits for the registry's answer to something asked (a patient chosen,
        Confirm, a new patient registered)."""
        return bool(self._asked)

    def drop_answers(self) -> None:
        """The window closes: answers still to come are not shown (the record's too)."""
        self._asked.clear()
        self.clinical.hold()

    def _picked(self, item: QListWidgetItem | None, _previous=None) -> None:
        if item is None:
            return
        patient = item.data(Qt.ItemDataRole.UserRole)
        current = self._choosing or self._patient
        if current is not None and patient.code == current.code:
            return
        self.choose(patient)

    def choose(self, patient: Patient) -> None:
        """Make this patient the current one: the choice is taken now (nobody confirmed,
        the tab says "Loading…"), their numbers and record are read on the job thread and
        shown once read (`_chosen`), if they are still the patient chosen then."""
        self._choices += 1
        self._choosing, self._patient = patient, None
        self._asked.pop("confirm", None)  # Confirm was for the patient before
        self._unconfirm()
        self.trial_problem.hide()
        self.patient_label.setText(describe(patient))
        self.measurements_label.setText("Loading the patient's record…")
        self.session_note.setText("")  # the patient before's; the numbers wait, greyed
        self.clinical.hold()
        registry, code = self.registry, patient.code
        if registry is None:
            self._choosing = None
            self._refresh_buttons()
            return
        self._ask("choice", lambda: read_choice(registry, code),
                  lambda read: self._chosen(patient, read))

    def _chosen(self, patient: Patient, read: Numbers | Exception) -> None:
        """Patient `patient`'s numbers and record as read: shown, and the patient said
        chosen (`patient_selected`); or, the registry unreadable, said in one line."""
        self._choosing = None
        if isinstance(read, Exception):
            self.measurements_label.setText("")
            self._show(self.trial_problem, f"{patient.code} could not be read: {read}. "
                       "Choose the patient again.")
            self.results.blockSignals(True)  # the same row chosen again reads again
            self.results.setCurrentRow(-1)
            self.results.blockSignals(False)
            self._refresh_buttons()
            self.choice_failed.emit(patient, str(read))
            return
        self._patient = patient
        self.measurements_label.setText(measurements(patient))
        self.clinical.set_patient(patient, read.suggestion.session_number, read.record[2])
        self.refresh_numbers(read)
        self._refresh_buttons()
        self.patient_selected.emit(patient)

    def _recorded(self, _said: str) -> None:
        """After a correction the patient's row changed: show it as it is now. A scale or a
        note may have opened a session: its line says so (`refresh_count`)."""
        self.refresh_count()
        patient = self.clinical.patient
        if patient is not None:
            self.show_changed(patient)

    def show_changed(self, patient: Patient) -> None:
        """The chosen patient's row as it is now, changed by a correction (the clinical
        record's, or the measurements kept from the Parameters tab): shown, the record
        told, and the tabs (patient_selected). A row of another patient is not shown."""
        if self._patient is None or patient.code != self._patient.code \
                or patient == self._patient:
            return
        self._patient = patient
        # the record's patient too: after its next scale or note it showed the row it last
        # corrected, the measurements kept since gone again
        self.clinical.patient_changed(patient)
        self.patient_label.setText(describe(patient))
        self.measurements_label.setText(measurements(patient))
        self.patient_selected.emit(patient)

    def _ask(self, kind: str, work: Callable[[], object],
             show: Callable[[object], None]) -> None:
        """`work` (which returns what the registry said, never raises) on the job thread,
        `show(answer)` once answered unless something of the same `kind` was asked since,
        or dropped (another patient chosen, the window closing)."""
        token = self._asked[kind] = object()

        def answered(answer: object) -> None:
            if self._asked.get(kind) is not token:
                return  # asked again, or dropped, since
            del self._asked[kind]
            self._refresh_buttons()
            show(answer)

        self._refresh_buttons()
        self.jobs.run(work, answered)

    def _refresh_buttons(self) -> None:
        """The buttons as what waits allows: Confirm and the numbers once a patient's
        record is shown, each waiting button saying what it waits for."""
        shown = self._patient is not None and self.registry is not None
        loading, checking = "choice" in self._asked, "confirm" in self._asked
        for box in (self.session, self.trial):
            box.setEnabled(shown and not loading)
        self.confirm.setEnabled(shown and not (loading or checking))
        self.confirm.setText(LOADING if loading else CHECKING if checking else CONFIRM)
        creating = "create" in self._asked
        self.create_button.setEnabled(not creating)
        self.create_button.setText(SAVING if creating else CREATE)

    # -- numbers --------------------------------------------------------------------
    def _session_edited(self, sessions: dict[int, Session] | None = None) -> None:
        if self._patient is None or self.registry is None:
            return
        if sessions is None:
            sessions = {s.number: s for s in self.registry.sessions(self._patient.code)}
        self._say_session(sessions)
        self._numbers_edited()

    def _say_session(self, sessions: dict[int, Session]) -> None:
        """Whether the session shown is new or goes on, from the patient's `sessions`."""
        session = sessions.get(self.session.value())
        if session is None:
            self.session_note.setText("a new session")
        else:
            self.session_note.setText(
                f"continues the session of {session.date.isoformat()} "
                f"({session.n_trials} trial{'s' if session.n_trials != 1 else ''} so far)")

    def _numbers_edited(self) -> None:
        self._unconfirm()
        self.trial_problem.hide()

    def _unconfirm(self) -> None:
        """The confirmed registration no longer holds: said to the window (`unconfirmed`),
        whose Start then waits for Confirm."""
        was = self._registration is not None
        self._registration = None
        self.confirmed.setText("")
        if was:
            self.unconfirmed.emit()

    def confirm_registration(self, numbers: Numbers | None = None) -> Registration | None:
        """Check the numbers shown against the registry and, if free, emit `registered`:
        at once with `numbers` when they were read for the numbers shown (the registration
        returned), else read on the job thread (Confirm says "Checking…") and confirmed
        once read if the patient and numbers shown are still those of the click."""
        patient = self._patient
        if patient is None or self.registry is None or "confirm" in self._asked:
            return None
        refused = commit_all((self.session, self.trial))
        if refused:
            self.show_refusal(refused[0])
            return None
        code, session, trial = patient.code, self.session.value(), self.trial.value()
        if numbers is not None and (numbers.code, numbers.suggestion.session_number,
                                    numbers.suggestion.trial_number) == (code, session, trial):
            return self._confirmed(patient, session, trial,
                                   (numbers.used, numbers.free, numbers.sessions))
        registry = self.registry

        def check() -> tuple | Exception:
            try:
                used = session_trials(registry, code, session)
                free = registry.next_trial_number(code, session) \
                    if isinstance(used, dict) and trial in used else trial
                return used, free, {s.number: s for s in registry.sessions(code)}
            except Exception as exc:  # RegistryError, a station's fault: said as is
                return exc

        def checked(read: tuple | Exception) -> None:
            if self._patient is not patient or \
                    (self.session.value(), self.trial.value()) != (session, trial):
                return  # another patient or other numbers since the click: Confirm again
            if isinstance(read, Exception):
                self.show_refusal(read)
                return
            self._confirmed(patient, session, trial, read)

        self._ask("confirm", check, checked)
        return None

    def _confirmed(self, patient: Patient, session: int, trial: int,
                   read: tuple) -> Registration | None:
        """Confirm with the registry's (trials of the session by number or its refusal,
        next free number, sessions by number)."""
        used, free, sessions = read
        code = patient.code
        if isinstance(used, RegistryError):
            self.show_refusal(used)
            return None
        if trial in used:
            started = used[trial].started_at.astimezone().strftime("%d %b %Y %H:%M")
            self.show_refusal(
                f"Patient {code} session {session} already has a trial {trial} (started "
                f"{started}); use {free}, the next free number.")
            return None
        gap = gap_refusal(code, session, trial, used, sessions)
        if gap:
            self.show_refusal(gap)
            return None
        self.trial_problem.hide()
        registration = Registration(code, session, trial,
                                    new_session=not used and session not in sessions)
        self._registration = registration
        self.confirmed.setText(f"Next trial: {code}, session {session}, trial {trial}.")
        self.bring_into_view(self.confirmed)
        self.registered.emit(patient, registration)
        return registration

    def _show(self, label: QLabel, message: str) -> None:
        label.setText(f"{theme.PROBLEM_SIGN} {message}")
        label.show()
        self.bring_into_view(label)

    def bring_into_view(self, widget: QWidget) -> None:
        """Scroll the forms so that `widget` is in view once laid out: the result of what
        the therapist just did, never below the fold (issue 27 #15)."""
        QTimer.singleShot(0, self.forms_scroll,
                          lambda: self.forms_scroll.ensureWidgetVisible(widget, 0, 24))

