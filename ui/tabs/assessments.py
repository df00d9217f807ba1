"""The Assessments tab (issue 31): the battery's tasks, each one's protocol to read aloud
(what the therapist does, what the patient is told, its trials, the robot's mode), a button
that puts a trial of the task in the Parameters form, so the window's own Build, Connect and
Start run it as any trial (the patient's screen shows its targets), and the patient's
latest figures of the task as its report page (app.reports.assessment_page) with the
norms' source under them (the isometric strength task's polar plot beside them:
ui.tabs.strength_polar), and the page saved as a PDF.

Qt only: the window (ui.window.assessments) fills it from the registry and the norms in use,
read on its job thread: the figures say "Loading…" meanwhile, and Save as PDF waits for them
(it saves the page shown).
"""

from __future__ import annotations

import re

from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QComboBox,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QTextBrowser,
    QVBoxLayout,
    QWidget,
)

from app.assessments.words import laps_words, planned_exercise_s, robot_task_words
from core.assessment import TASK_TITLES, TASKS, task_figures
from core.assessment.protocol import protocol
from core.assessment.strength import StrengthPolar
from core.holdtasks import ROBOT_TASKS
from core.trial import THESIS_SUBJECT
from ui import theme
from ui.tabs.strength_polar import StrengthPolarPlot

LOADING = "Loading…"
SAVE_PDF = "Save as PDF…"


class AssessmentsTab(QWidget):
    use_requested = Signal(str, int)
    """A task and the index of its trial to put in the Parameters form."""
    pdf_requested = Signal(str)
    """The task whose report page to save as a PDF."""
    task_changed = Signal(str)

    def __init__(self) -> None:
        super().__init__()
        self.task = QComboBox()
        for task in TASKS:
            self.task.addItem(TASK_TITLES[task], task)
        self.trial = QComboBox()
        self.use_button = QPushButton("Set up this trial")
        self.use_button.setToolTip("Put the task's trial in the Parameters form; then Build, "
                                   "Connect and Start run it")
        self.use_button.clicked.connect(
            lambda: self.use_requested.emit(self.current_task(), self.trial.currentIndex()))
        self.pdf_button = QPushButton(SAVE_PDF)
        self.pdf_button.setEnabled(False)  # until a page is shown
        self.pdf_button.clicked.connect(lambda: self.pdf_requested.emit(self.current_task()))
        top = QHBoxLayout()
        top.addWidget(QLabel("Task:"))
        top.addWidget(self.task, 2)
        top.addWidget(QLabel("Trial:"))
        top.addWidget(self.trial, 1)
        top.addWidget(self.use_button)
        self.setup = QLabel("")
        self.setup.setWordWrap(True)
        self.protocol_text = QTextBrowser()
        self.results = QTextBrowser()
        self.polar = StrengthPolarPlot()
        self.polar.hide()
        results_row = QHBoxLayout()
        results_row.addWidget(theme.set_role(QLabel("The patient's latest figures"),
                                             "heading"), 1)
        results_row.addWidget(self.pdf_button)
        left = QVBoxLayout()
        left.addWidget(theme.set_role(QLabel("Protocol"), "heading"))
        left.addWidget(self.protocol_text, 1)
        right = QVBoxLayout()
        right.addLayout(results_row)
        figures = QHBoxLayout()
        figures.addWidget(self.results, 1)
        figures.addWidget(self.polar, 1)
        right.addLayout(figures, 1)
        columns = QHBoxLayout()
        columns.addLayout(left, 1)
        columns.addLayout(right, 1)
        layout = QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(self.setup)
        layout.addLayout(columns, 1)
        self.task.currentIndexChanged.connect(self._task_chosen)
        self._task_chosen()

    def current_task(self) -> str:
        return self.task.currentData()

    def choose(self, task: str) -> None:
        self.task.setCurrentIndex(self.task.findData(task))

    def _task_chosen(self, *_args) -> None:
        task = self.current_task()
        spec = protocol(task)
        self.trial.clear()
        for index, label in enumerate(spec.trials):
            self.trial.addItem(f"{index + 1} of {spec.trial_count}" + (f": {label}" if label
                                                                        else ""))
        self.protocol_text.setPlainText(protocol_words(task))
        self.task_changed.emit(task)

    def show_results(self, lines: list[str], polar: StrengthPolar | None = None, *,
                     page: bool = False) -> None:
        """The report page's lines (app.reports.assessment_page.page_text), or why none,
        and its polar plot beside them when it has one (the strength task's); hidden
        otherwise. `page`: the lines are a page, which Save as PDF then saves."""
        self.results.setPlainText("\n".join(unbroken(line) for line in lines))
        if polar is not None:
            self.polar.show_polar(polar)
        self.polar.setVisible(polar is not None)
        self.pdf_button.setText(SAVE_PDF)
        self.pdf_button.setEnabled(page)

    def show_loading(self, what: str) -> None:
        """The figures being read (`what`, in words): "Loading…" where they will be, and
        Save as PDF waiting for them; the rest of the tab works meanwhile."""
        self.show_results([f"{LOADING} {what}"])
        self.pdf_button.setText(LOADING)

    def show_setup(self, text: str) -> None:
        """What the Parameters form holds now for the task, and what to press."""
        self.setup.setText(text)


NUMBER_THEN_WORD = re.compile(r"(?<=\d) (?=[^\s\d(])")
"""The space after a number and before its unit (or its noun), as in '10.6 N'."""


def unbroken(line: str) -> str:
    """`line` with a number and the unit after it held together (a no-break space): the
    panel wrapped 'Peak force (mean of directions): 10.6' above a lone 'N'."""
    return NUMBER_THEN_WORD.sub("\u00a0", line)


def protocol_words(task: str) -> str:
    """The protocol as the tab shows it: the trials, the robot, the words for the therapist
    and for the patient, the figures measured and the instrument followed."""
    spec = protocol(task)
    trials = (f"{spec.trial_count} trials: " + ", ".join(spec.trials) if spec.trial_count > 1
              else "1 trial")
    exercise = (f"{spec.n_targets} targets {spec.radius_m * 100:g} cm from the centre"
                if spec.shape == "targets" else f"a circle of {spec.radius_m * 100:g} cm radius")
    figures = "\n".join(f"  • {figure.label}" for figure in task_figures(task))
    if task in ROBOT_TASKS:
        runs = f"1 trial: {robot_task_words(spec.parameters(THESIS_SUBJECT))}"
    else:
        laps = laps_words(spec.parameters(THESIS_SUBJECT))
        total = round(planned_exercise_s(spec.parameters(THESIS_SUBJECT)), 1)
        runs = (f"{trials}, {'each ' if spec.trial_count > 1 else ''}{laps} ({total:g} s); "
                f"{exercise}; the robot {spec.robot_mode}")
    return (f"{TASK_TITLES[task]}: {runs}.\n\n"
            f"For the therapist:\n{spec.therapist}\n\n"
            f"Read to the patient:\n{spec.patient}\n\n"
            f"Figures:\n{figures}\n\nFollows: {spec.reference}")
