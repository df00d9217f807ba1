"""The Progress tab: every figure of every trial of one patient, as a table and as a plot
of one chosen figure over the trials.

A figure only compares between trials of the same exercise (a larger D makes the
position error larger while the patient improves), so the plot groups the points
by parameter set (`app.reports.progress`): one colour, one symbol and one joining line
per set, named in the legend. The registry query runs off the GUI thread.
"""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, Signal
from PySide6.QtWidgets import (
    QHBoxLayout,
    QHeaderView,
    QLabel,
    QSplitter,
    QTableWidget,
    QTableWidgetItem,
    QVBoxLayout,
    QWidget,
)

from app.records.store import RecordStore
from app.reports.metrics_table import ROWS
from app.reports.progress import Progress, progress
from ui import plots, theme
from ui.fields import ComboBox
from ui.views.progress_table import (
    metric_heading,
    metric_rows,
    progress_summary,
    progress_table,
    tick_label,
    value_span,
)

DEFAULT_METRIC = "directional_performance_pct"
MAX_LABELLED_TICKS = 30


class ProgressTab(QWidget):
    """Signals: progress_loaded(Progress), progress_failed(message)."""

    progress_loaded = Signal(object)
    progress_failed = Signal(str)

    def __init__(self, registry: RecordStore | None = None, parent=None) -> None:
        super().__init__(parent)
        self.registry = registry
        self._code: str | None = None
        self._progress: Progress | None = None
        self.background = plots.Background(self)
        self.background.done.connect(self._loaded)
        self.background.failed.connect(self._failed)

        self.heading = theme.set_role(QLabel("Progress"), "heading")
        self.message = theme.set_role(QLabel("Choose a patient on the Registration tab."),
                                      "caption")
        self.message.setWordWrap(True)
        self.metric_choice = ComboBox()
        self.metric_choice.setAccessibleName("Figure to plot")
        self.metric_choice.currentIndexChanged.connect(self._draw_plot)
        top = QHBoxLayout()
        top.addWidget(self.heading)
        top.addStretch(1)
        top.addWidget(QLabel("Figure"))
        top.addWidget(self.metric_choice)

        self.plot = plots.make_plot("trial (session.trial)", "")
        item = self.plot.getPlotItem()
        self.legend = plots.legend(item)
        self.table = QTableWidget()
        self.table.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.table.verticalHeader().hide()
        self.table.setAlternatingRowColors(True)
        splitter = QSplitter(Qt.Orientation.Vertical)
        splitter.addWidget(self.plot)
        splitter.addWidget(self.table)
        splitter.setSizes([500, 300])
        layout = QVBoxLayout(self)
        layout.addLayout(top)
        layout.addWidget(self.message)
        layout.addWidget(splitter, 1)

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
            self._clear()
            self.message.setText("Choose a patient on the Registration tab.")
            return
        self.message.setText("Loading…")
        registry = self.registry
        self.background.submit(code, lambda: progress(registry, code))

    def refresh(self) -> None:
        self.set_patient(self._code)

    # -- results --------------------------------------------------------------------
    def _loaded(self, code, result: Progress) -> None:
        if code != self._code:
            return
        self._progress = result
        self.heading.setText(f"Progress of {code}")
        self.message.setText(progress_summary(result))
        self._fill_metrics(result)
        self._fill_table(result)
        self._draw_plot()
        self.progress_loaded.emit(result)

    def _failed(self, code, message: str) -> None:
        if code != self._code:
            return
        self._progress = None
        self._clear()
        self.message.setText(f"{theme.PROBLEM_SIGN} {message}")
        self.progress_failed.emit(message)

    def _clear(self) -> None:
        self.table.clear()
        self.table.setRowCount(0)
        self.table.setColumnCount(0)
        self.plot.getPlotItem().clear()
        self.legend.clear()
        self.metric_choice.blockSignals(True)
        self.metric_choice.clear()
        self.metric_choice.blockSignals(False)

    def _fill_metrics(self, result: Progress) -> None:
        current = self.metric_choice.currentData() or DEFAULT_METRIC
        self.metric_choice.blockSignals(True)
        self.metric_choice.clear()
        for row in metric_rows(result):
            self.metric_choice.addItem(metric_heading(row), row.key)
        index = self.metric_choice.findData(current)
        self.metric_choice.setCurrentIndex(max(index, 0))
        self.metric_choice.blockSignals(False)

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

    def _draw_plot(self) -> None:
        result = self._progress
        item = self.plot.getPlotItem()
        item.clear()
        self.legend.clear()
        key = self.metric_choice.currentData()
        if result is None or key is None:
            return
        row = next(r for r in ROWS if r.key == key)
        item.setLabel("left", metric_heading(row))
        theme.style_plot(item)
        complete = np.array([t.status == "complete" for t in result.trials])
        shown: list[np.ndarray] = []
        for series in result.series(key):
            i = series.parameter_set_index
            colour = theme.SERIES[i % len(theme.SERIES)]
            symbol = theme.SYMBOLS[i % len(theme.SYMBOLS)]
            values = series.values * row.scale
            shown.append(values)
            line = pg.PlotDataItem(
                series.trial_index + 1, values,
                pen=theme.pen(colour), symbol=symbol, symbolSize=11,
                symbolPen=theme.pen(colour), symbolBrush=pg.mkBrush(colour),
                name=series.parameter_set.label())
            item.addItem(line)
            # a trial that did not run to its end (stopped, a safety fault, a lost
            # recording) is drawn hollow: its figures cover only part of the exercise
            partial = ~complete[series.trial_index]
            if partial.any():
                item.addItem(pg.ScatterPlotItem(
                    series.trial_index[partial] + 1, values[partial], symbol=symbol, size=15,
                    pen=theme.pen(theme.VERMILLION), brush=pg.mkBrush("w")))
        if (~complete).any():
            self.legend.addItem(pg.ScatterPlotItem(symbol="o", size=12,
                                                   pen=theme.pen(theme.VERMILLION),
                                                   brush=pg.mkBrush("w")),
                                "did not run to its end")
        axis = item.getAxis("bottom")
        if len(result) <= MAX_LABELLED_TICKS:
            # "S1 T2", not "1.2": session and trial, not a decimal
            axis.setTicks([[(int(k) + 1, tick_label(s, t)) for k, s, t in
                            zip(result.trial_index, result.session, result.trial, strict=True)]])
        else:
            axis.setTicks(None)
        if len(result):
            item.setXRange(0.5, len(result) + 0.5, padding=0)
            low, high = value_span(np.concatenate(shown) if shown else np.array([]), row.unit)
            if low < high:
                item.setYRange(low, high, padding=0.05)
