"""The Registration tab's Find a patient box (a part of ui.tabs.registration.RegistrationTab):
a fragment of a name or a code typed, the registry searched off the window's thread once
typing pauses, and the patients found listed, the one chosen kept current.

Why off the window's thread: on a station whose network went silent a search waited the
registry's bounded wait (app.records.registry.postgres.deadline, 5 s) with the window
frozen.
"""

from __future__ import annotations

from PySide6.QtCore import Qt, QTimer
from PySide6.QtWidgets import (
    QGroupBox,
    QLabel,
    QLineEdit,
    QListWidget,
    QListWidgetItem,
    QVBoxLayout,
)

from app.records.registry import Patient
from ui import plots, theme
from ui.tabs.patient_words import describe

SEARCH_DELAY_MS = 150


class PatientSearch:
    """Find a patient (a part of RegistrationTab, which has `registry`, `_choosing`,
    `_patient` and `_picked`)."""

    def _find_box(self) -> QGroupBox:
        """The box's fields (attributes of the tab), their search wired to the registry."""
        self._search_timer = QTimer(self)
        self._search_timer.setSingleShot(True)
        self._search_timer.setInterval(SEARCH_DELAY_MS)
        self._search_timer.timeout.connect(self.search)
        self.searching = plots.Background(self)
        self.searching.done.connect(self._found)
        self.searching.failed.connect(self._search_failed)
        self._search_text: str | None = None  # the text of the newest search asked for

        self.search_field = QLineEdit()
        self.search_field.setPlaceholderText("part of a name, or a code")
        self.search_field.setAccessibleName("Find a patient")
        self.search_field.setClearButtonEnabled(True)
        self.search_field.textChanged.connect(lambda _text: self._search_timer.start())
        self.results = QListWidget()
        self.results.setAccessibleName("Patients found")
        self.results.currentItemChanged.connect(self._picked)
        self.found = theme.set_role(QLabel(""), "caption")
        find = QGroupBox("Find a patient")
        column = QVBoxLayout(find)
        column.addWidget(self.search_field)
        column.addWidget(self.results, 1)
        column.addWidget(self.found)
        return find

    def search(self) -> None:
        """Search the registry for the text typed (on the tab's own thread); the list
        shows what the newest search found once it is found (`_found`)."""
        self._search_timer.stop()
        if self.registry is None:
            self.results.clear()
            self.found.setText("No registry is open.")
            return
        text = self._search_text = self.search_field.text()
        self.found.setText("Searching…")
        self.searching.submit(text, self.registry.search_patients, text)

    def _found(self, text: str, patients: list[Patient]) -> None:
        """The patients a search for `text` found, listed when it is still the newest."""
        if text != self._search_text:
            return
        # Filled without a word to `_picked`: the list makes its first item current as it
        # is filled, and this arrives whenever the search ends, so another patient than
        # the one chosen meanwhile was chosen in the therapist's place. The current item
        # is the chosen patient, or none.
        self.results.blockSignals(True)
        try:
            self.results.clear()
            for patient in patients:
                item = QListWidgetItem(describe(patient))
                item.setData(Qt.ItemDataRole.UserRole, patient)
                self.results.addItem(item)
            self.results.setCurrentRow(-1)
            current = self._choosing or self._patient
            if current is not None:
                self._select_in_list(current.code)
        finally:
            self.results.blockSignals(False)
        self.found.setText(f"{len(patients)} patient{'s' if len(patients) != 1 else ''} found"
                           if text.strip() else f"{len(patients)} registered")

    def _search_failed(self, text: str, message: str) -> None:
        if text == self._search_text:
            self.results.clear()
            self.found.setText(f"{theme.PROBLEM_SIGN} {message}")

    def _select_in_list(self, code: str) -> None:
        for row in range(self.results.count()):
            item = self.results.item(row)
            if item.data(Qt.ItemDataRole.UserRole).code == code:
                self.results.setCurrentItem(item)
                return
