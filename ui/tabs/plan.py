"""The Plan tab: today's session plan for the patient chosen. A template copied to the
patient, the plan's blocks in a table (laps, pace, level, tolerance and rest changed in
place for today: each change is kept as a new plan, the one before as it was), and the
plan's own buttons: Start plan (after Build and Connect), Pause, Resume and Stop plan,
with the plan's status line (block k of n, movements, the rest's countdown). While a plan
runs, and after, the table shows its blocks as the run runs them (`show_run`: a proposal
taken, in bold, named under the table). While the
registry is asked (the window's job thread: the plan read, a copy or a change saved, a run
begun) the tab says so and its table, Copy and Start plan wait (`show_waiting`).

Qt only: the window (ui.window.plan) keeps the registry, the runner and the robot.
"""

from __future__ import annotations

import math

from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QPushButton,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from app.games.names import GAME_TITLES
from app.reports.progress import MODE_NAMES
from core.plan import Block, Plan
from ui.tabs.parameters_fields import SHAPE_NAMES

COLUMNS = ("Block", "Exercise", "Game", "Rounds", "Laps", "Pace (s a lap)", "Mode",
           "Level (%)", "Tolerance (°)", "Rest (s)")
EDITABLE = {1: "shape", 2: "game", 3: "rounds", 4: "repetitions", 5: "duration_s",
            6: "assist", 7: "assistance_level", 8: "tolerance_rad", 9: "rest_s"}
"""Table column -> the block's field it changes (in the column's display unit; a game is
'path', 'reach' or empty for none)."""
TEXT_FIELDS = ("shape", "game", "assist")
TEXT_NAMES = {"shape": SHAPE_NAMES, "game": {"": "none", **GAME_TITLES}, "assist": MODE_NAMES}
"""A text field's codes -> the names a cell shows, as the Parameters and Progress tabs name
them ('D shape', 'Reaching game', 'As needed'; the cells read 'd', 'reach', 'as-needed').
A cell takes either back."""


def text_value(field: str, text: str) -> str:
    """The code a typed `text` names in a text field ('As needed' or 'as-needed':
    'as-needed'; 'none' or nothing: no game); anything else as typed, for Block to refuse."""
    typed = text.strip().lower()
    for code, name in TEXT_NAMES[field].items():
        if typed in (code, name.lower()):
            return code
    if field == "game" and typed in ("-", "none"):
        return ""
    return typed.removesuffix(" game") if field == "game" else typed


class PlanTab(QWidget):
    copy_requested = Signal(str)
    block_changed = Signal(int, object)  # block index, the changed Block
    start_requested = Signal()
    pause_requested = Signal()
    resume_requested = Signal()
    stop_requested = Signal()

    def __init__(self, templates: list[tuple[str, str, str]]) -> None:
        """`templates`: (name, title, about) each (app.plans.templates.template_titles):
        the list shows the titles, what each is for as its tooltip, and Copy gives the
        name (the list showed the files' names, "endurance")."""
        super().__init__()
        self.plan: Plan | None = None
        self._run: tuple[Plan, tuple[Block, ...]] | None = None
        """The plan run and its blocks as the runner runs them (or ran them), shown in
        place of the plan's while it is the plan shown."""
        self._loading = False
        self.waiting = ""
        """What the registry is being asked for, in words ('' when nothing is)."""
        self._running = (False, False)
        self.templates = QComboBox()
        for k, (name, title, about) in enumerate(templates):
            self.templates.addItem(title, name)
            self.templates.setItemData(k, about, Qt.ItemDataRole.ToolTipRole)
        self.copy_button = QPushButton("Copy to the patient")
        self.copy_button.clicked.connect(
            lambda: self.copy_requested.emit(self.templates.currentData()))
        top = QHBoxLayout()
        top.addWidget(QLabel("Template:"))
        top.addWidget(self.templates, 1)
        top.addWidget(self.copy_button)
        # what the chosen template holds, in view before it is copied: only its tooltip
        # said it, and the list showed a bare "Endurance" over an empty table
        self.about = QLabel("")
        self.about.setWordWrap(True)
        self.templates.currentIndexChanged.connect(self._show_about)
        self._show_about()
        self.title = QLabel("No patient chosen: choose one on the Registration tab.")
        self.title.setWordWrap(True)
        self.table = QTableWidget(0, len(COLUMNS))
        self.table.setHorizontalHeaderLabels(COLUMNS)
        # the first column numbers the blocks ("1. Reaching game"): Qt's own row numbers
        # beside it read "1 | 1. Reaching game"
        self.table.verticalHeader().setVisible(False)
        # each column as wide as its heading and cells (Qt's 100 px cut "1. Warm-up on the
        # D" and "Pace (s a lap)" at 1366 px, beside a third of the table left empty)
        header = self.table.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        header.setStretchLastSection(True)
        self.table.itemChanged.connect(self._edited)
        self.refusal = QLabel("")
        self.refusal.setWordWrap(True)
        self.refusal.setStyleSheet("color: #b00;")
        self.start_button = QPushButton("Start plan")
        self.pause_button = QPushButton("Pause")
        self.resume_button = QPushButton("Resume")
        self.stop_button = QPushButton("Stop plan")
        for button, signal in ((self.start_button, self.start_requested),
                               (self.pause_button, self.pause_requested),
                               (self.resume_button, self.resume_requested),
                               (self.stop_button, self.stop_requested)):
            button.clicked.connect(signal.emit)
        buttons = QHBoxLayout()
        for button in (self.start_button, self.pause_button, self.resume_button,
                       self.stop_button):
            buttons.addWidget(button)
        buttons.addStretch(1)
        self.status = QLabel("")
        self.status.setWordWrap(True)
        self.status.setStyleSheet("font-weight: bold;")
        self.waiting_line = QLabel("")
        self.waiting_line.setStyleSheet("font-style: italic;")
        # its line kept when empty: the table under it stays put (it moved down as the
        # therapist's change was being saved, and back up)
        self.waiting_line.setMinimumHeight(self.waiting_line.fontMetrics().lineSpacing())
        column = QVBoxLayout(self)
        column.addLayout(top)
        column.addWidget(self.about)
        column.addWidget(self.title)
        column.addWidget(self.waiting_line)
        column.addWidget(self.table, 1)
        self.run_changes = QLabel("")
        self.run_changes.setWordWrap(True)
        column.addWidget(self.run_changes)
        column.addWidget(self.refusal)
        column.addLayout(buttons)
        column.addWidget(self.status)
        self.show_running(False, False)

    def set_plan(self, plan: Plan | None, title: str) -> None:
        """Show `plan` (None: none yet) under `title`; the run's blocks stay in its place
        while it is the plan run (the window reads the stored plan again at the run's end:
        the table showed the plan and not what ran)."""
        self.plan = plan
        if self._run is not None and self._run[0] != plan:
            self._run = None
        self.title.setText(title)
        self.refusal.setText("")
        self._fill()

    def show_run(self, plan: Plan, blocks) -> None:
        """The blocks of `plan` as its run runs them (app.plans.runner.PlanRunner.blocks:
        the console's proposal after a trial applies to a later block of the same
        exercise), and after the run as they ran. The table said the plan's 4 s a lap
        while the robot ran block 3 at the proposal's 4.5 s."""
        run = (plan, tuple(blocks))
        if run != self._run:
            self._run = run
            self._fill()

    def _fill(self) -> None:
        plan = self.plan
        planned = plan.blocks if plan is not None else ()
        shown = self._run[1] if self._run is not None and len(self._run[1]) == len(planned) \
            else planned
        changes = []
        self._loading = True
        try:
            self.table.setRowCount(len(shown))
            for row, block in enumerate(shown):
                cells, plan_cells = _cells(row, block), _cells(row, planned[row])
                changed = [f"{COLUMNS[col].lower()} {text} (planned {plan_cells[col]})"
                           for col, text in enumerate(cells) if text != plan_cells[col]]
                if changed:
                    changes.append(f"block {row + 1}, " + ", ".join(changed))
                for col, text in enumerate(cells):
                    item = QTableWidgetItem(text)
                    if col not in EDITABLE or (col == 4 and block.repetitions is None):
                        item.setFlags(item.flags() & ~_editable_flag())
                    if text != plan_cells[col]:
                        font = item.font()
                        font.setBold(True)
                        item.setFont(font)
                        item.setToolTip(f"The plan says {plan_cells[col]}: {PROPOSED}.")
                    self.table.setItem(row, col, item)
        finally:
            self._loading = False
        self.run_changes.setText(
            f"Changed in this run by the console's proposal: {'; '.join(changes)}."
            if changes else "")

    def _show_about(self) -> None:
        about = self.templates.currentData(Qt.ItemDataRole.ToolTipRole) or ""
        self.about.setText(f"{self.templates.currentText()}: {about}" if about else "")

    def show_running(self, running: bool, paused: bool) -> None:
        """Which of the plan's buttons apply."""
        self._running = (running, paused)
        free = not running and not self.waiting
        self.start_button.setEnabled(free and self.plan is not None)
        self.pause_button.setEnabled(running and not paused)
        self.resume_button.setEnabled(running and paused)
        self.stop_button.setEnabled(running)
        self.copy_button.setEnabled(free)
        self.table.setEnabled(free)

    def show_waiting(self, words: str) -> None:
        """The registry is being asked for `words` ('' : its answer is shown): Start plan,
        Copy and the table wait meanwhile (a Start plan pressed while a change was being
        saved ran the plan before it, the table showing the change)."""
        self.waiting = words
        self.waiting_line.setText(words)
        self.show_running(*self._running)

    def show_refusal(self, text: str) -> None:
        self.refusal.setText(text)

    def _edited(self, item: QTableWidgetItem) -> None:
        if self._loading or self.plan is None:
            return
        row, col = item.row(), item.column()
        if self.waiting:  # the table waits (disabled): a change made another way is not sent
            self._refuse(row, f"the plan is not shown yet ({self.waiting.rstrip('…')}): "
                              "change it once it is")
            return
        block = self.plan.blocks[row]
        field = EDITABLE.get(col)
        text = item.text().strip()
        if field in TEXT_FIELDS:
            value = text_value(field, text)
        else:
            try:
                value = float(text.replace(",", "."))
            except ValueError:
                self._refuse(row, f"block {row + 1}: {COLUMNS[col]} {text!r} is not a number")
                return
        if field in ("repetitions", "rounds"):
            value = int(value) if value == int(value) else value
        elif field == "assistance_level":
            value = value / 100.0
        elif field == "tolerance_rad":
            value = math.radians(value)
        try:
            changed = Block.from_dict({**block.to_dict(), field: value}, f"block {row + 1}")
        except Exception as exc:  # ParameterError: one line naming the block and field
            self._refuse(row, str(exc))
            return
        self.refusal.setText("")
        self.block_changed.emit(row, changed)

    def _refuse(self, row: int, text: str) -> None:
        self.refusal.setText(f"Not changed: {text}")
        self.set_plan(self.plan, self.title.text())  # the cell shows the plan again
        self.refusal.setText(f"Not changed: {text}")


PROPOSED = ("the console's proposal after an earlier trial of the same exercise changed "
            "it for this run")


def _cells(row: int, block: Block) -> tuple[str, ...]:
    laps = str(block.repetitions) if block.repetitions is not None else (
        f"{block.laps} ({block.active_s / 60:g} min)")
    return (f"{row + 1}. {block.name}" if block.name else str(row + 1),
            TEXT_NAMES["shape"].get(block.shape, block.shape),
            TEXT_NAMES["game"].get(block.game, block.game), str(block.rounds), laps,
            f"{block.duration_s:g}", TEXT_NAMES["assist"].get(block.assist, block.assist),
            f"{block.assistance_level * 100:.0f}",
            f"{math.degrees(block.tolerance_rad):.0f}", f"{block.rest_s:g}")


def _editable_flag():
    from PySide6.QtCore import Qt

    return Qt.ItemFlag.ItemIsEditable
