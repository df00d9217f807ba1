"""The Assessments tab's part of the window (issue 31): a task's trial put in the Parameters
form (so Build, Connect and Start run it as any trial), whether the form still holds it,
and the patient's latest figures of the task as its report page, saved as a PDF."""

from __future__ import annotations

import logging
from pathlib import Path

from PySide6.QtWidgets import QFileDialog

from app.errors import AppError
from app.reports.assessment_page import page_text, patient_page, write_assessment_pdf
from core.assessment import TASK_TITLES
from core.assessment.protocol import protocol
from core.errors import CoreError
from core.trial import TrialParameters
from ui.tabs.assessments import AssessmentsTab

log = logging.getLogger("ui.main_window")


class AssessmentControl:
    """The Assessments tab and its task set up in the form (a part of MainWindow)."""

    def _build_assessments_tab(self) -> AssessmentsTab:
        self.assessments_tab = AssessmentsTab()
        self.assessments_tab.use_requested.connect(self.set_up_assessment)
        self.assessments_tab.task_changed.connect(lambda _t: self.show_assessment())
        self.assessments_tab.pdf_requested.connect(lambda task: self.save_assessment_pdf(task))
        self.parameters_tab.parameters_changed.connect(lambda *_: self._show_assessment_setup())
        return self.assessments_tab

    def set_up_assessment(self, task: str, index: int) -> None:
        """Put trial `index` of `task` in the Parameters form, on the patient's body and the
        table the form shows (core.assessment.protocol: the task fixes the exercise, timing
        and robot mode); Build then runs it."""
        base = self.parameters_tab.shown() or TrialParameters(assist="as-needed")
        try:
            trial = protocol(task).parameters(base, index)
        except CoreError as exc:
            self._say(f"The {TASK_TITLES[task].lower()} cannot be set up: {exc}", problem=True)
            return
        self.parameters_tab.set_parameters(trial)
        self.parameters_tab.edited.emit()
        self._say(f"{TASK_TITLES[task]}, trial {index + 1} of {protocol(task).trial_count}, "
                  "is in the Parameters form: press Build, Connect and Start.")
        self._show_assessment_setup()

    def _show_assessment_setup(self) -> None:
        shown = self.parameters_tab.shown()
        task = shown.assessment if shown is not None else ""
        if task:
            spec = protocol(task)
            label = (f" ({'clockwise' if shown.clockwise else 'counter-clockwise'})"
                     if spec.trial_count > 1 else "")
            text = (f"The Parameters form holds the {spec.name}{label}: Build, Connect and "
                    "Start run it.")
        else:
            text = ("The Parameters form holds an exercise, not a task: press Set up this "
                    "trial.")
        self.assessments_tab.show_setup(text)

    def show_assessment(self) -> None:
        """The patient's latest figures of the tab's task (its report page)."""
        task = self.assessments_tab.current_task()
        if self.patient is None:
            self.assessments_tab.show_results(["No patient chosen: choose one on the "
                                               "Registration tab."])
            return
        try:
            page = patient_page(self.registry, self.patient.code, task)
        except AppError as exc:
            self.assessments_tab.show_results([f"The figures cannot be shown: {exc}"])
            return
        if page is None:
            self.assessments_tab.show_results([f"{self.patient.code} has no "
                                               f"{protocol(task).name} yet."])
            return
        self.assessments_tab.show_results(page_text(page), page.polar)

    def save_assessment_pdf(self, task: str, path: str | Path | None = None) -> Path | None:
        """The task's report page as a PDF at `path` (asked for when None)."""
        if self.patient is None:
            self._say("Choose a patient first.", problem=True)
            return None
        page = patient_page(self.registry, self.patient.code, task)
        if page is None:
            self._say(f"{self.patient.code} has no {protocol(task).name} to save.",
                      problem=True)
            return None
        if path is None:
            folder = self.registry.data_dir.root
            path, _ = QFileDialog.getSaveFileName(
                self, "Save the assessment", str(folder / f"{self.patient.code}_{task}.pdf"),
                "PDF (*.pdf)")
            if not path:
                return None
        try:
            written = write_assessment_pdf(path, [page])
        except AppError as exc:
            self._say(str(exc), problem=True)
            return None
        self._say(f"Saved {written.name}.")
        return written
