"""The console's proposal for the next trial (app.trials.progression), above the
Parameters tab's form where it stays in view: what to change and why, and *Use the
proposal*, which puts it into the form (a change like any other: Build takes it).

It is shown after a trial and, after a restart, for the chosen patient's last trial when
the registry still holds its proposal as pending; it goes when the patient changes.
"""

from __future__ import annotations

from PySide6.QtCore import Signal
from PySide6.QtWidgets import QGroupBox, QHBoxLayout, QLabel, QPushButton

from core.errors import capitalised


class ProposalBox(QGroupBox):
    """Signals: taken(Proposal) when the therapist presses Use the proposal."""

    taken = Signal(object)

    def __init__(self) -> None:
        super().__init__("Proposed for the next trial")
        self.setObjectName("proposal_box")
        self.text = QLabel("")
        self.text.setWordWrap(True)
        self.use = QPushButton("Use the proposal")
        self.use.clicked.connect(self._use)
        row = QHBoxLayout(self)
        row.addWidget(self.text, 1)
        row.addWidget(self.use)
        self.proposal = None
        self._task = ""  # the assessment task the form holds (hold_for_task)
        self.hide()

    def hold_for_task(self, task: str) -> None:
        """While the form holds an assessment task (`task`, '' for none) the proposal waits
        for the next exercise trial: taken, it changed a field the task's protocol fixes
        and so turned the task's trial into an exercise with a word nowhere but in the
        form (ui.tabs.parameters_form, _assessment_of)."""
        if task == self._task:
            return
        self._task = task
        self.use.setEnabled(not task)
        self.use.setToolTip(
            "The form holds an assessment task, whose protocol is fixed: the proposal is "
            "for the next exercise trial." if task else "")

    def show_proposal(self, proposal, *, after: str = "") -> None:
        """Show `proposal` (None hides the box); `after` says which trial it follows when
        that is not the one just run (after a restart). A proposal that changes nothing is
        shown without the button."""
        self.proposal = proposal
        if proposal is None:
            self.hide()
            return
        reason = capitalised(proposal.reason) + "."
        self.text.setText(f"{after} {reason}".strip())
        self.use.setVisible(proposal.change != "none")
        self.show()

    def _use(self) -> None:
        if self.proposal is None:
            return
        self.taken.emit(self.proposal)
        self.text.setText(self.text.text() + " Taken: press Build.")
        self.use.hide()
