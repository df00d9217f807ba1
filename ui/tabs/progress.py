"""The Progress tab: one exercise's series at a time (the assistance mode and the exercise:
app.reports.progress), the chosen figure over its trials — the mode's own success figure
first — and under it, on the same trial axis, the robot's help as it ran, a staircase,
with the pace and the tolerance written where they changed; then every trial of the
patient in a table, and a robot figure against the clinical scales with their correlation
(ui.tabs.progress_scales). Trials marked invalid are left out unless the tick box asks.
The key is a line above the plots, never over the data. *Save as PDF…* writes the same,
a page an exercise (app.reports.progress_pdf). The registry query and the PDF run off the
GUI thread.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QFontMetrics
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QFileDialog,
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QPushButton,
    QStackedWidget,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from app.records.datadir import REPORTS
from app.records.store import RecordStore
from app.reports.progress import Exercise, Progress, progress
from app.reports.progress_figure import (
    figure_rows,
    progress_figure,
    trial_limits,
    value_span,
)
from ui import plots, theme
from ui.fields import ComboBox
from ui.tabs.progress_scales import ScalesPanel
from ui.tabs.progress_sizes import Splitter, axis_width, fit_choice, label_least
from ui.views.progress_table import (
    exercise_choice,
    metric_heading,
    progress_summary,
    progress_table,
    split_sizes,
)

MAX_LABELLED_TICKS = 30
HELP_TOP = 150.0  # the help plot's top (%): room above 100 % for the pace and tolerance
HELP_COLOUR = theme.SERIES[2]
PLOT_LEAST_LINES = 5.5  # the series plot's readable least, in text lines: four ticks
HELP_LEAST_LINES = 5.0  # the help plot's: its trial axis, its title and 0-100 %
POINT_PX = 11  # a trial that ran the whole exercise: a filled disc
CUT_SHORT_PX = 15  # one that did not: a hollow ring, larger, off the line
MARKER_ROOM_PX = 0.5 * CUT_SHORT_PX + 2  # the largest marker's radius and its pen's width
VALUE_PADDING = 0.05  # the series' span's share left above and below it
KEY = (f"<span style='color:{theme.BLUE}'>●</span> complete &nbsp; "
       f"<span style='color:{theme.VERMILLION}'>○</span> did not run to its end &nbsp; "
       f"<span style='color:{HELP_COLOUR}'>━</span> the robot's help as it ran (%), "
       "<b>◆</b> changed during the trial; the pace and the tolerance written where they "
       "changed")


def _write_pdf(result: Progress, path: Path, registry=None) -> Path:
    from app.plans.dose import patient_doses
    from app.reports.progress_pdf import write_progress_pdf  # matplotlib on first use
    from app.reports.scales_progress import report_series

    if registry is None:
        return write_progress_pdf(result, path)
    from app.norms.in_use import norms_in_use

    code = result.patient_code
    included = any(t.invalid_reason for t in result.trials)
    # a change is real against the norms in use (their MDC95), as the scales panel marks it
    return write_progress_pdf(result, path, doses=patient_doses(registry, code),
                              scales=registry.session_scales(code),
                              series=report_series(registry, result, include_invalid=included,
                                                   norms=norms_in_use(registry.data_dir)))


class ProgressTab(QWidget):
    """Signals: progress_loaded(Progress), progress_failed(message), pdf_saved(Path)."""

    progress_loaded = Signal(object)
    progress_failed = Signal(str)
    pdf_saved = Signal(object)

    def __init__(self, registry: RecordStore | None = None, parent=None) -> None:
        super().__init__(parent)
        self.registry = registry
        self._code: str | None = None
        self._token: tuple | None = None  # the progress asked for last: (code, invalid)
        self._progress: Progress | None = None
        self._mode: str | None = None  # the shown exercise's assistance mode
        self._exercise: Exercise | None = None  # the shown exercise
        self.background = plots.Background(self)
        self.background.done.connect(self._loaded)
        self.background.failed.connect(self._failed)
        self.writer = plots.Background(self)
        self.writer.done.connect(self._saved)
        self.writer.failed.connect(self._failed)

        self.heading = theme.set_role(QLabel("Progress"), "heading")
        self.message = theme.set_role(QLabel("Choose a patient on the Registration tab."),
                                      "caption")
        self.message.setWordWrap(True)
        self.exercise_choice = ComboBox()
        self.exercise_choice.setAccessibleName("Exercise to plot")
        self.exercise_choice.currentIndexChanged.connect(self._exercise_changed)
        self.metric_choice = ComboBox()
        self.metric_choice.setAccessibleName("Figure to plot")
        self.metric_choice.currentIndexChanged.connect(self._draw_plot)
        # the exercise's name whole ("As needed · D shape, r 10.0 cm · SMC", _fit); the
        # figures' list opens wider than its box
        self.metric_choice.setSizeAdjustPolicy(
            QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
        self.metric_choice.setMinimumContentsLength(22)
        self.pdf_button = QPushButton("Save as PDF…")
        self.pdf_button.clicked.connect(self._choose_pdf)
        self.pdf_button.setEnabled(False)
        top = QHBoxLayout()
        top.addWidget(self.heading)
        top.addStretch(1)
        # trials marked invalid (schema v8) are left out unless asked for here
        self.include_invalid = QCheckBox("Include trials marked invalid")
        self.include_invalid.toggled.connect(self.refresh)
        top.addWidget(self.include_invalid)
        self.scales_button = QPushButton("Clinical scales")
        self.scales_button.setCheckable(True)
        self.scales_button.setToolTip("A robot figure against the clinical scales, with "
                                      "their correlation, in the table's place")
        self.scales_button.toggled.connect(self._show_scales)
        top.addWidget(self.scales_button)
        top.addWidget(self.pdf_button)
        choices = QHBoxLayout()  # a row of their own: whole names at any font scale
        choices.addWidget(QLabel("Exercise"))
        choices.addWidget(self.exercise_choice)
        choices.addSpacing(12)
        choices.addWidget(QLabel("Figure"))
        choices.addWidget(self.metric_choice)
        choices.addStretch(1)

        # the session plans' dose: movements, active time and rest of the latest runs
        self.dose = theme.set_role(QLabel(""), "caption")
        self.dose.setWordWrap(True)
        self.dose.setVisible(False)  # only with plans to show: the plots keep their room
        self.dose_worker = plots.Background(self)
        self.dose_worker.done.connect(self._dose_loaded)
        self.dose_worker.failed.connect(
            lambda code, message: code == self._code and self.dose.setText(
                f"{theme.PROBLEM_SIGN} The plans' dose could not be read: {message}"))
        self.key = theme.set_role(QLabel(KEY), "caption")
        self.key.setWordWrap(True)
        self.plot = plots.make_plot("", "")
        self.help_plot = plots.make_plot("trial (session, trial)", "help (%)")
        self.help_plot.setXLink(self.plot)
        self._value_span: tuple[float, float] | None = None
        self._trial_count = 0
        self._marks: list[tuple[pg.TextItem, float]] = []  # the pace's, over their trial
        self.plot.getPlotItem().getViewBox().sigResized.connect(self._fit_values)
        self.plot.getPlotItem().getViewBox().sigResized.connect(self._fit_trials)
        self.table = QTableWidget()
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.table.verticalHeader().hide()
        self.table.setAlternatingRowColors(True)
        # the plots and the trials' table share the height by split_sizes (the table a
        # few rows whole, the plots their readable least) until the therapist drags a
        # handle; then their sizes are the therapist's
        self._split_dragged = False
        self.splitter = Splitter(self._fit_split)
        self.splitter.splitterMoved.connect(self._split_moved)
        self.splitter.addWidget(self.plot)
        self.splitter.addWidget(self.help_plot)
        # the trials' table, and a robot figure against the clinical scales
        # (app.reports.scales_progress), one page each, in the table's place when asked
        # (the button above): a laptop's height holds the plots and one of the two; the
        # scales panel scrolls when short
        self.scales = ScalesPanel()
        self.scales.setMinimumHeight(260)  # the scatter readable
        self.lower = QStackedWidget()
        self.lower.addWidget(self.table)
        self.lower.addWidget(plots.vertical_scroll(self.scales, 0))
        self.splitter.addWidget(self.lower)
        # no part asks the window for more height than a laptop has: the table scrolls
        for k in range(3):
            self.splitter.setStretchFactor(k, 1)
        layout = QVBoxLayout(self)
        layout.addLayout(top)
        layout.addLayout(choices)
        layout.addWidget(self.message)
        layout.addWidget(self.dose)
        layout.addWidget(self.key)
        layout.addWidget(self.splitter, 1)

    # -- public -------------------------------------------------------------------
    @property
    def progress(self) -> Progress | None:
        return self._progress

    def set_registry(self, registry: RecordStore) -> None:
        self.registry = registry

    def set_patient(self, code: str | None) -> None:
        """Show this patient's progress (None: nobody chosen). Call again after a trial."""
        self._code = code
        if code is None or self.registry is None:
            self._progress = None
            self._token = None
            self._clear()
            self.scales.set_patient(None, None)
            self.message.setText("Choose a patient on the Registration tab.")
            return
        self.message.setText("Loading…")
        registry = self.registry
        include_invalid = self.include_invalid.isChecked()
        # the token names the request: a result of an earlier one (before the tick box
        # changed) that arrives late is not shown
        self._token = (code, include_invalid)
        self.background.submit(self._token, lambda: progress(registry, code,
                                                             include_invalid=include_invalid))
        self.scales.set_patient(registry, code, include_invalid)
        from app.plans.dose import dose_lines

        self.dose.setText("")
        self.dose_worker.submit(code, lambda: dose_lines(registry, code))

    def _show_scales(self, on: bool) -> None:
        """The scales panel in the table's place, with the plots' room too: a laptop's
        height holds the scatter (the trial plots come back with the button)."""
        self.lower.setCurrentIndex(1 if on else 0)
        for plot in (self.plot, self.help_plot):
            plot.setVisible(not on)
        self.key.setVisible(not on)
        self._fit_split()

    def _split_moved(self, *_) -> None:
        self._split_dragged = True

    def _fit_split(self) -> None:
        """The plots' and the table's default heights (split_sizes) for the room the
        splitter has now and the table's rows, unless the therapist has dragged a handle
        or the scales panel has the room."""
        if self._split_dragged or self.plot.isHidden():
            return
        table = self.table
        line = QFontMetrics(self.font()).height()
        chrome = (table.horizontalHeader().sizeHint().height()
                  + table.horizontalScrollBar().sizeHint().height() + 2 * table.frameWidth())
        room = self.splitter.height() - 2 * self.splitter.handleWidth()
        sizes = split_sizes(room, table.rowCount(),
                            table.verticalHeader().defaultSectionSize(), chrome,
                            max(round(PLOT_LEAST_LINES * line), label_least(self.plot)),
                            max(round(HELP_LEAST_LINES * line), label_least(self.help_plot)))
        if list(sizes) != self.splitter.sizes():
            self.splitter.setSizes(list(sizes))

    def refresh(self, *_) -> None:
        self.set_patient(self._code)

    def save_pdf(self, path: str | Path) -> None:
        """Write the progress PDF (a page an exercise) off the GUI thread; pdf_saved(path)
        follows."""
        if self._progress is None:
            raise RuntimeError("no progress to save yet")
        self.message.setText("Saving the PDF…")
        self.writer.submit(("pdf", Path(path)), _write_pdf, self._progress, Path(path),
                           self.registry)

    # -- results --------------------------------------------------------------------
    def _loaded(self, token, result: Progress) -> None:
        if token != self._token:
            return
        code = token[0]
        self._progress = result
        self.heading.setText(f"Progress of {code}")
        self.message.setText(progress_summary(result))
        self._fill_exercises(result)
        self._fill_table(result)
        self.pdf_button.setEnabled(len(result) > 0)
        self.progress_loaded.emit(result)

    def _dose_loaded(self, code, lines: list[str]) -> None:
        if code == self._code:
            self.dose.setText("Session plans: " + "; ".join(lines) if lines else "")
            self.dose.setVisible(bool(lines))

    def _failed(self, token, message: str) -> None:
        if isinstance(token, tuple) and token[0] == "pdf":
            self.message.setText(f"{theme.PROBLEM_SIGN} Could not save the PDF: {message}")
            return
        if token != self._token:
            return
        self._progress = None
        self._clear()
        self.message.setText(f"{theme.PROBLEM_SIGN} {message}")
        self.progress_failed.emit(message)

    def _saved(self, token, path: Path) -> None:
        self.message.setText(f"Saved {path}")
        self.pdf_saved.emit(path)

    def _clear(self) -> None:
        self.table.clear()
        self.table.setRowCount(0)
        self.table.setColumnCount(0)
        self.plot.getPlotItem().clear()
        self.help_plot.getPlotItem().clear()
        self.pdf_button.setEnabled(False)
        for choice in (self.exercise_choice, self.metric_choice):
            choice.blockSignals(True)
            choice.clear()
            choice.blockSignals(False)

    def _fill_exercises(self, result: Progress) -> None:
        shown = self._exercise
        self.exercise_choice.blockSignals(True)
        self.exercise_choice.clear()
        for index in range(len(result.exercises)):
            self.exercise_choice.addItem(exercise_choice(result, index))
        # the same exercise as before (a new trial of it), else the latest trial's
        if shown in result.exercises:
            index = result.exercises.index(shown)
        else:
            index = int(result.exercise_index[-1]) if len(result) else 0
        self.exercise_choice.setCurrentIndex(index)
        fit_choice(self.exercise_choice)
        self.exercise_choice.blockSignals(False)
        self._exercise_changed()

    def _exercise_changed(self) -> None:
        result = self._progress
        index = self.exercise_choice.currentIndex()
        self.metric_choice.blockSignals(True)
        current = self.metric_choice.currentData()
        self.metric_choice.clear()
        if result is not None and index >= 0:
            self._exercise = result.exercises[index]
            # the series' own figures: an assessment task's for its runs (app.reports)
            for row in figure_rows(result, index):
                self.metric_choice.addItem(metric_heading(row), row.key)
            # in the same mode keep the figure; another mode opens on its own success figure
            mode = result.exercises[index].mode
            found = self.metric_choice.findData(current) if mode == self._mode else -1
            self.metric_choice.setCurrentIndex(found if found >= 0 else 0)
            self._mode = mode
        self.metric_choice.blockSignals(False)
        self._draw_plot()

    def _fill_table(self, result: Progress) -> None:
        table = progress_table(result)
        self.table.clear()
        self.table.setColumnCount(len(table.headings))
        self.table.setRowCount(len(table.rows))
        self.table.setHorizontalHeaderLabels(table.headings)
        for i, cells in enumerate(table.rows):
            for c, text in enumerate(cells):
                cell = QTableWidgetItem(text)
                if table.right_aligned(c):
                    cell.setTextAlignment(Qt.AlignmentFlag.AlignRight
                                          | Qt.AlignmentFlag.AlignVCenter)
                self.table.setItem(i, c, cell)
        self.table.horizontalHeader().setSectionResizeMode(
            QHeaderView.ResizeMode.ResizeToContents)
        self._fit_split()

    def _draw_plot(self) -> None:
        result = self._progress
        item, help_item = self.plot.getPlotItem(), self.help_plot.getPlotItem()
        item.clear()
        help_item.clear()
        self._value_span = None
        self._trial_count, self._marks = 0, []
        index = self.exercise_choice.currentIndex()
        key = self.metric_choice.currentData()
        if result is None or index < 0 or key is None:
            return
        figure = progress_figure(result, index, key)
        # the short name on the axis: the chooser above says it whole
        item.setLabel("left", figure.row.heading_in_unit)
        theme.style_plot(item)
        theme.style_plot(help_item)
        width = axis_width()
        for axis in (item.getAxis("left"), help_item.getAxis("left")):
            axis.setWidth(width)
        x, y = figure.positions.astype(float), figure.values
        shown = np.isfinite(y)
        # the line joins the trials that ran the whole exercise; one that did not (stopped,
        # a safety fault, a lost recording) is drawn hollow, off the line: its figures
        # cover only part of the exercise and make no trend with the others
        whole = shown & figure.complete
        item.addItem(pg.PlotDataItem(x[whole], y[whole], pen=theme.pen(theme.BLUE),
                                     symbol="o", symbolSize=POINT_PX,
                                     symbolPen=theme.pen(theme.BLUE),
                                     symbolBrush=pg.mkBrush(theme.BLUE)))
        partial = shown & ~figure.complete
        if partial.any():
            item.addItem(pg.ScatterPlotItem(x[partial], y[partial], symbol="o",
                                            size=CUT_SHORT_PX,
                                            pen=theme.pen(theme.VERMILLION),
                                            brush=pg.mkBrush("w")))
        help_item.addItem(pg.PlotDataItem(figure.help_x, figure.help_y,
                                          pen=pg.mkPen(HELP_COLOUR, width=2),
                                          connect="finite"))
        if figure.live_x.size:
            help_item.addItem(pg.ScatterPlotItem(figure.live_x, figure.live_y, symbol="d",
                                                 size=10, pen=theme.pen(theme.TEXT),
                                                 brush=pg.mkBrush(theme.TEXT)))
        for mark in figure.marks:
            # hung from the top of the plot, over the trial where the setting changed
            text = pg.TextItem(mark.text, color=theme.TEXT, anchor=(0.5, 0.0))
            text.setFont(theme.axis_font())
            text.setPos(mark.position, HELP_TOP)
            help_item.addItem(text)
            self._marks.append((text, float(mark.position)))
        help_item.setYRange(0.0, HELP_TOP, padding=0)
        help_item.getAxis("left").setTicks([[(v, f"{v}") for v in (0, 50, 100)]])
        n = len(figure.positions)
        axis = help_item.getAxis("bottom")
        if n <= MAX_LABELLED_TICKS:
            axis.setTicks([list(zip(figure.positions.tolist(), figure.ticks, strict=True))])
        else:
            axis.setTicks(None)
        item.getAxis("bottom").setTicks([[(p, "") for p in figure.positions.tolist()]])
        if n:
            self._trial_count = n
            self._fit_trials()
            low, high = value_span(y, figure.row.unit)
            self._value_span = (low, high) if low < high else None
            self._fit_values()

    def _fit_trials(self, *_) -> None:
        """The trial axis: the first and the last trial's markers whole at its ends, and
        each pace and tolerance written whole over its trial. Padded by half a trial, 300
        trials on a laptop's plot left 1.3 px beside the end markers (drawn half cut) and
        cut the first trial's pace in half at the left; the room is worked out in pixels,
        again at each resize."""
        n = self._trial_count
        if not n:
            return
        item = self.plot.getPlotItem()
        width = max(item.getViewBox().width(), 1.0)
        low, high = trial_limits(n, width, MARKER_ROOM_PX)
        item.setXRange(low, high, padding=0)
        trials_per_px = (high - low) / width
        for text, position in self._marks:
            # centred over its trial, or as near as keeps it whole inside the plot
            half = 0.5 * text.boundingRect().width() * trials_per_px
            text.setPos(min(max(position, low + half), max(high - half, low + half)),
                        HELP_TOP)

    def _fit_values(self, *_) -> None:
        """The series' y axis: its values' span (value_span) and room above and below for
        a whole marker. Padded by 5 % of the span alone, the axis ended 3–5 px above
        100 % on a laptop's plot, and a trial at 100 % cut short (a 15 px ring) was drawn
        half cut at the top; the room is worked out in pixels, again at each resize."""
        if self._value_span is None:
            return
        low, high = self._value_span
        box = self.plot.getPlotItem().getViewBox()
        span = high - low
        height = box.height()
        # a pad p (value units) shows span + 2p over the box's height: the marker's
        # radius r (px) fits when p ≥ r·span / (height − 2r)
        room = MARKER_ROOM_PX * span / max(height - 2 * MARKER_ROOM_PX, 1.0)
        pad = max(VALUE_PADDING * span, room)
        box.setYRange(low - pad, high + pad, padding=0)

    def _choose_pdf(self) -> None:
        if self._progress is None or self.registry is None:
            return
        folder = self.registry.data_dir.ensure(REPORTS, self._progress.patient_code)
        suggested = Path(folder) / f"{self._progress.patient_code}_progress.pdf"
        path, _ = QFileDialog.getSaveFileName(self, "Save the progress", str(suggested),
                                              "PDF (*.pdf)")
        if path:
            self.save_pdf(path)
