"""The Report tab's table for the therapist: every figure of the trial, this trial's value,
the earlier trials' beside it (app.reports.compare.TableRow), and what each figure means.

Read whole on a laptop: the figures and the earlier trials' values within the view (an
earlier trial's heading is its name over what it was, wrapped as on the PDF; on one line it
made a column 530 px wide for 'was 89.45'), the meanings in the room left but never
narrower than MEANING_CHARS characters (then the table, and only it, scrolls sideways);
each row as tall as its text at the widths shown (measured before the table was laid out,
the meanings wrapped in a narrow column and every row stood three to five lines tall); the
table as tall as all its rows: the page scrolls, not the table.
"""

from __future__ import annotations

import textwrap

from PySide6.QtCore import Qt
from PySide6.QtWidgets import QHeaderView, QSizePolicy, QTableWidget, QTableWidgetItem

from app.reports.content import ReportContent

MEANING_CHARS = 36  # the longest meaning (67 characters) on two lines


def earlier_heading(column: str) -> str:
    """'Previous D shape trial (session 2, trial 1, 11 May 2026; not compared)' as its name
    on the first line and what it was below, wrapped no wider than the name."""
    name, _, detail = column.partition(" (")
    if not detail:
        return name
    return "\n".join([name, *textwrap.wrap(f"({detail}", max(len(name), 20))])


class FigureTable(QTableWidget):
    """The figures of one report (see the module's docstring)."""

    def __init__(self, content: ReportContent, parent=None) -> None:
        columns = ["Figure", "This trial", *map(earlier_heading, content.table_columns),
                   "What it means"]
        super().__init__(len(content.table), len(columns), parent)
        self.setHorizontalHeaderLabels(columns)
        self.verticalHeader().hide()
        self.setEditTriggers(QTableWidget.EditTrigger.NoEditTriggers)
        self.setWordWrap(True)
        for r, row in enumerate(content.table):
            unit = f" {row.unit}" if row.unit and row.unit != "°" else row.unit
            cells = [row.label, f"{row.value_text}{unit}", *row.earlier_texts, row.meaning]
            for c, text in enumerate(cells):
                self.setItem(r, c, QTableWidgetItem(text))
        header = self.horizontalHeader()
        header.setSectionResizeMode(QHeaderView.ResizeMode.ResizeToContents)
        header.setSectionResizeMode(self.meaning_column, QHeaderView.ResizeMode.Fixed)
        # a column's width changes (the view, the font): the meanings' and every row's
        # height follow
        header.sectionResized.connect(self._column_resized)
        self.setVerticalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        self.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Fixed)
        self._fit_meanings()

    @property
    def meaning_column(self) -> int:
        return self.columnCount() - 1

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        self._fit_meanings()

    def _fit_meanings(self) -> None:
        """The meanings take the room the figures leave, at least MEANING_CHARS wide."""
        header = self.horizontalHeader()
        figures = sum(max(header.sectionSizeHint(c), self.sizeHintForColumn(c))
                      for c in range(self.meaning_column))
        least = MEANING_CHARS * self.fontMetrics().averageCharWidth()
        self.setColumnWidth(self.meaning_column,
                            max(least, self.viewport().width() - figures))
        self.resizeRowsToContents()
        self._whole_height()

    def _column_resized(self, column: int, _old: int, _new: int) -> None:
        if column != self.meaning_column:
            self._fit_meanings()
        else:
            self.resizeRowsToContents()
            self._whole_height()

    def _whole_height(self) -> None:
        rows = sum(self.rowHeight(r) for r in range(self.rowCount()))
        self.setFixedHeight(self.horizontalHeader().sizeHint().height() + rows
                            + self.horizontalScrollBar().sizeHint().height()
                            + 2 * self.frameWidth())
