"""The Assessments tab's part of the window (issue 31): a task's trial put in the Parameters
form (so Build, Connect and Start run it as any trial), whether the form still holds it,
and the patient's latest figures of the task as its report page, saved as a PDF.

The page is read on the window's job thread (ui.jobs), when the tab is shown: it reads the
registry (the patient's trials, the marks of invalid ones, the patient's record), the norms
in use and, with norms, the trial's file. Read on the window's thread, on a shared registry
whose network went silent each call waited the registry's bounded wait
(app.records.registry.postgres.deadline), the window frozen meanwhile. The tab says
"Loading…" until the answer and works otherwise; an answer is shown only if it is the last
one asked, for the patient still chosen; a read that fails is said on the message line with
its cause; the window closing does not wait for it. An answer that comes while another
patient's record is being read is dropped, the tab saying it waits for them: their figures
come once they are chosen, or, their record unreadable, the tab says so (it said
"Loading…" for ever). Save as PDF saves the page shown.
"""

from __future__ import annotations

import logging
from pathlib import Path

from PySide6.QtWidgets import QFileDialog

from app.errors import AppError
from app.reports.assessment_page import (
    AssessmentPage,
    page_text,
    patient_page,
    write_assessment_pdf,
)
from core.assessment import TASK_TITLES
from core.assessment.protocol import protocol
from core.errors import CoreError
from core.trial import TrialParameters
from device.loop.states import State
from ui.tabs.assessments import AssessmentsTab

log = logging.getLogger("ui.main_window")


class AssessmentControl:
    """The Assessments tab and its task set up in the form (a part of MainWindow)."""

    _assessment_asked: object | None = None
    """The read of the figures the tab waits for (`show_assessment`), None when none."""
    _assessment_shown: tuple[str, str, AssessmentPage | None] | None = None
    """(patient code, task, their page or None: no such trial) the tab shows, as read."""
    _assessment_waits_for: str | None = None
    """The patient whose record the tab waits for (being chosen), None when it does not."""

    def _build_assessments_tab(self) -> AssessmentsTab:
        self.assessments_tab = AssessmentsTab()
        self.assessments_tab.use_requested.connect(self.set_up_assessment)
        self.assessments_tab.task_changed.connect(lambda _t: self.show_assessment())
        self.assessments_tab.pdf_requested.connect(lambda task: self.save_assessment_pdf(task))
        self.registration_tab.choice_failed.connect(self._assessment_choice_failed)
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
                  f"is in the Parameters form: press {self._buttons_to_run()}.")
        self._show_assessment_setup()

    def _buttons_to_run(self) -> str:
        """The robot buttons that run the form's trial from here, in order: "Build,
        Connect and Start" said Connect to a connected robot, whose Connect is greyed."""
        press = [] if self.built is not None and not self.stale() else ["Build"]
        if self.state != State.CONNECTED:
            press.append("Connect")
        press.append("Start")
        return press[0] if len(press) == 1 else f"{', '.join(press[:-1])} and {press[-1]}"

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
        """The patient's latest figures of the tab's task (its report page), read on the job
        thread while the tab is shown (again each time it is shown)."""
        tab = self.assessments_tab
        task = tab.current_task()
        self._assessment_asked = self._assessment_shown = None  # an answer coming is stale
        self._assessment_waits_for = None
        if self.patient is None:
            tab.show_results(["No patient chosen: choose one on the Registration tab."])
            return
        if self.tabs.currentWidget() is not tab:
            tab.show_results([])  # read when the tab is shown, not at every choice
            return
        code, registry, name = self.patient.code, self.registry, protocol(task).name
        asked = self._assessment_asked = object()
        tab.show_loading(f"reading {code}'s {name} from the registry.")

        def read() -> AssessmentPage | Exception | None:
            try:
                return patient_page(registry, code, task)
            except Exception as exc:  # the registry gone, a damaged record: said, not raised
                return exc

        def answered(page: AssessmentPage | Exception | None) -> None:
            if self.jobs.closed or self._assessment_asked is not asked:
                return  # the window closed, or another task or patient asked for since
            self._assessment_asked = None
            choosing = self.registration_tab.choosing()
            if choosing is not None and choosing.code != code:
                # another patient chosen, their record still being read: theirs come next
                tab.show_loading(f"{choosing.code}'s record is being read.")
                self._assessment_waits_for = choosing.code
                return
            if isinstance(page, Exception):
                log.error("the %s of %s could not be read", name, code, exc_info=page)
                tab.show_results([f"The figures cannot be shown: {page}"])
                self._say(f"{code}'s {name} could not be read: {page}. Show the Assessments "
                          "tab again to read it again.", problem=True)
                return
            self._assessment_shown = (code, task, page)
            if page is None:
                tab.show_results([f"{code} has no {name} yet."])
                return
            tab.show_results(page_text(page), page.polar, page=True)

        self.jobs.run(read, answered)

    def _assessment_choice_failed(self, patient, message: str) -> None:
        """The record of the patient the tab waits for could not be read: no figures
        come, so the tab says why and what to do (the Registration tab says it too)."""
        if self._assessment_waits_for != patient.code:
            return
        self._assessment_waits_for = None
        self.assessments_tab.show_results([f"{patient.code}'s record could not be read: "
                                           f"{message}. Choose the patient again on the "
                                           "Registration tab."])

    def assessment_reading(self) -> bool:
        """The tab waits for the figures it asked for."""
        return self._assessment_asked is not None

    def _close_assessment(self) -> bool:
        """The window closes: the figures being read are not waited for (their answer is
        dropped, the job thread ending after it). True when a read was waited for."""
        asked, self._assessment_asked = self._assessment_asked, None
        return asked is not None

    def save_assessment_pdf(self, task: str, path: str | Path | None = None) -> Path | None:
        """The task's report page the tab shows as a PDF at `path` (asked for when
        None): the page as read, never read again here."""
        if self.patient is None:
            self._say("Choose a patient first.", problem=True)
            return None
        code, name = self.patient.code, protocol(task).name
        shown = self._assessment_shown
        if shown is None or shown[:2] != (code, task):
            self._say(f"{code}'s {name} is not shown yet: show it on the Assessments tab, "
                      "then save it.", problem=True)
            return None
        page = shown[2]
        if page is None:
            self._say(f"{code} has no {name} to save.", problem=True)
            return None
        if path is None:
            folder = self.registry.data_dir.root
            path, _ = QFileDialog.getSaveFileName(
                self, "Save the assessment", str(folder / f"{code}_{task}.pdf"),
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
