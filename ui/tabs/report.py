"""The Report tab: after a trial, what it showed in large plain words, for the patient
(the mode's own success figure first, the change since last time, no coordinates, seeds,
file names or instructions to the therapist), then the therapist's part beneath (every
setting, each fault with what to do, every figure, the notes); printable and savable as
the PDF report, whose page 1 and page 2 are these two parts.

The content is `app.reports.build.ReportContent`, the same object the PDF draws, so the
screen and the paper cannot disagree. Building it reads the trial file and
writing the PDF runs matplotlib: both happen off the GUI thread.

Printing goes through Qt (QPrintDialog) as a text document of the same content:
the figures are on the other tabs and in the saved PDF.
"""

from __future__ import annotations

import html
from pathlib import Path

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt, Signal
from PySide6.QtGui import QTextDocument
from PySide6.QtPrintSupport import QPrintDialog, QPrinter
from PySide6.QtWidgets import (
    QFileDialog,
    QFormLayout,
    QHBoxLayout,
    QLabel,
    QPushButton,
    QScrollArea,
    QVBoxLayout,
    QWidget,
)

from app.records.store import RecordStore
from app.reports.build import (
    PathFigure,
    ReportContent,
    build_report,
    content_for_registry_trial,
    write_report_pdf,
)
from app.trials.reader import read_trial
from app.units import CM_PER_M
from ui import plots, theme
from ui.tabs.report_table import FigureTable
from ui.views.trialview import TrialView

WAITING = "The report appears here once the trial is saved."


def _load_file(path: Path, options: dict) -> ReportContent:
    return build_report(read_trial(path), **options)


class ReportTab(QWidget):
    """Signals: report_ready(ReportContent), report_failed(message), pdf_saved(Path)."""

    report_ready = Signal(object)
    report_failed = Signal(str)
    pdf_saved = Signal(object)

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._content: ReportContent | None = None
        self._source: Path | None = None
        self._wanted: object = None  # the newest report asked for: only it may show
        self.path_plot: pg.PlotWidget | None = None  # the patient's path, once a report shows
        self.pdf_folder = ""  # where Save as PDF… starts: the patient's reports folder
        # Two queues: a newer report request replaces a waiting one, but must never
        # replace a PDF the therapist asked to save.
        self.background = plots.Background(self)
        self.writer = plots.Background(self)
        for worker in (self.background, self.writer):
            worker.done.connect(self._done)
            worker.failed.connect(self._failed)

        self.print_button = QPushButton("Print…")
        self.print_button.clicked.connect(self.print_report)
        self.pdf_button = theme.set_role(QPushButton("Save as PDF…"), "primary")
        self.pdf_button.clicked.connect(self._choose_pdf)
        self.message = theme.set_role(QLabel(WAITING), "caption")
        self.message.setWordWrap(True)
        buttons = QHBoxLayout()
        buttons.addWidget(self.message, 1)
        buttons.addWidget(self.print_button)
        buttons.addWidget(self.pdf_button)

        self.page = QWidget()
        self.page_layout = QVBoxLayout(self.page)
        self.page_layout.setSpacing(14)
        scroll = QScrollArea()
        scroll.setWidgetResizable(True)
        # the page is as wide as the view, so the patient's lines wrap at any font size;
        # only the therapist's table scrolls sideways
        scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
        scroll.setWidget(self.page)
        layout = QVBoxLayout(self)
        layout.addLayout(buttons)
        layout.addWidget(scroll, 1)
        self._set_buttons()

    # -- loading ------------------------------------------------------------------
    @property
    def content(self) -> ReportContent | None:
        return self._content

    def show_view(self, view: TrialView) -> None:
        """A replayed or saved trial: its report, built once from its file."""
        if view.source is None:
            if self._content is None:
                self.message.setText(WAITING)
            return
        if view.source != self._source:
            self.load_file(view.source)

    def show_waiting(self) -> None:
        """No trial on view has a report yet (none saved since the console started): the
        page empties and says so."""
        self._wanted = None
        self._source = None
        self._content = None
        self._clear()
        self._set_buttons()
        theme.set_role(self.message, "caption")
        self.message.style().polish(self.message)
        self.message.setText(WAITING)

    def load_file(self, path: str | Path, **options) -> None:
        """Build the report of a trial file (options go to app.reports.build.build_report)."""
        self._source = Path(path)
        token = self._preparing(("content", self._source))
        self.background.submit(token, _load_file, self._source, options)

    def registry_trial(self) -> int | None:
        """The id of the registered trial whose report is shown or prepared, None when it
        is a file's (a replayed or saved trial) or none."""
        wanted = self._wanted
        return wanted[1] if isinstance(wanted, tuple) and wanted[0] == "content" \
            and isinstance(wanted[1], int) else None

    def load_registry_trial(self, registry: RecordStore, trial_id: int) -> None:
        """A registered trial's report, compared with the patient's earlier trials."""
        self._source = None
        token = self._preparing(("content", trial_id))
        self.background.submit(token, lambda: content_for_registry_trial(registry, trial_id))

    def _preparing(self, token: object) -> object:
        """The page empties and Print and Save grey out while a new report is prepared:
        the previous trial's report, left on show with Save enabled, was taken for the
        trial just ended (and saved as if it were its report)."""
        self._wanted = token
        self._content = None
        self._clear()
        self._set_buttons()
        theme.set_role(self.message, "caption")
        self.message.style().polish(self.message)
        self.message.setText("Preparing the report…")
        return token

    def _done(self, token, result) -> None:
        kind = token[0]
        if kind == "content":
            if token == self._wanted:  # an older request's report is not this one's
                self.show_content(result)
        elif kind == "pdf":
            self.message.setText(f"Saved {result}")
            self.pdf_saved.emit(result)

    def _failed(self, token, message: str) -> None:
        if token[0] == "content" and token != self._wanted:
            return
        what = "save the PDF" if token[0] == "pdf" else "prepare the report"
        self.message.setText(f"{theme.PROBLEM_SIGN} Could not {what}: {message}")
        theme.set_role(self.message, "problem")
        self.message.style().polish(self.message)
        self.report_failed.emit(message)

    # -- drawing ------------------------------------------------------------------
    def show_content(self, content: ReportContent) -> None:
        self._content = content
        self._source = content.source
        theme.set_role(self.message, "caption")
        self.message.style().polish(self.message)
        self.message.setText(f"Report of {_which(content)}")
        self._clear()
        add = self.page_layout.addWidget
        # -- the patient's part (the PDF's page 1)
        add(theme.set_role(QLabel(content.title), "heading"))
        self.page_layout.addLayout(_form(content.header))
        if content.simulated:
            add(self._wrapped(SIMULATED, "caption"))
        if content.status_text:
            add(self._wrapped(content.status_text, "banner"))
        if content.plain:
            add(theme.set_role(QLabel("How it went"), "heading"))
        for k, line in enumerate(content.plain):
            pair = QVBoxLayout()
            pair.setSpacing(2)
            # the headline, the mode's own success figure, largest
            pair.addWidget(self._wrapped(line.text, "big" if k == 0 else "lead"))
            pair.addWidget(self._wrapped(line.detail, "caption"))
            self.page_layout.addLayout(pair)
        if content.comparisons:
            add(theme.set_role(QLabel("Since last time"), "heading"))
        for comparison in content.comparisons:
            add(self._wrapped(comparison.title, "lead"))
            for change in comparison.changes:
                add(self._wrapped(_change_text(change), "body"))
            for caution in comparison.cautions:
                add(self._wrapped(_not_compared(caution), "caption"))
        if content.path is not None:
            add(theme.set_role(QLabel("Your hand's path and the path to follow"), "heading"))
            add(self._wrapped(_path_key(content.path), "caption"))  # the key, off the data
            self.path_plot = _path_plot(content.path)
            add(self.path_plot)
            add(self._wrapped(SEEN_FROM_THE_SEAT, "caption"))
        # -- the therapist's part (the PDF's page 2)
        add(theme.set_role(QLabel("For the therapist"), "heading"))
        self.page_layout.addLayout(_form(content.therapist_header, problem="Fault"))
        if content.table:
            add(FigureTable(content))
        for note in content.notes:
            add(self._wrapped(note, "caption"))
        self.page_layout.addStretch(1)
        self._set_buttons()
        self.report_ready.emit(content)

    def _wrapped(self, text: str, role: str) -> QLabel:
        label = theme.set_role(QLabel(text), role)
        label.setWordWrap(True)
        label.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        # the role's font (the style sheet's) before the layout asks how tall the wrapped
        # text is: else a large font's second line is cut off
        label.ensurePolished()
        return label

    def _clear(self) -> None:
        self.path_plot = None
        while self.page_layout.count():
            item = self.page_layout.takeAt(0)
            if item.widget() is not None:
                item.widget().hide()  # gone at once, not at the loop's next pass
                item.widget().deleteLater()
            elif item.layout() is not None:
                _delete_layout(item.layout())

    def _set_buttons(self) -> None:
        ready = self._content is not None
        self.print_button.setEnabled(ready)
        self.pdf_button.setEnabled(ready)

    def lines(self) -> list[str]:
        """The texts on the page, top to bottom (what a person reads)."""
        return _texts(self.page_layout)

    # -- paper --------------------------------------------------------------------
    def document(self) -> QTextDocument:
        """The report as a text document for printing: the patient's part, then the
        therapist's, as on the screen."""
        content = self._content
        if content is None:
            raise RuntimeError("no report to print yet")
        e = html.escape

        def rows(items) -> str:
            return "<table>" + "".join(f"<tr><td><b>{e(i.label)}</b></td><td>{e(i.value)}</td>"
                                       "</tr>" for i in items) + "</table>"

        parts = [f"<h1>{e(content.title)}</h1>", rows(content.header)]
        if content.simulated:
            parts.append(f"<p><small>{e(SIMULATED)}</small></p>")
        if content.status_text:
            parts.append(f"<p><b>{e(content.status_text)}</b></p>")
        for k, line in enumerate(content.plain):
            size = 20 if k == 0 else 16
            parts.append(f"<p style='font-size:{size}pt'><b>{e(line.text)}</b></p>"
                         f"<p>{e(line.detail)}</p>")
        if content.comparisons:
            parts.append("<h2>Since last time</h2>")
        for comparison in content.comparisons:
            parts.append(f"<h3>{e(comparison.title)}</h3>")
            parts += [f"<p>{e(_change_text(c))}</p>" for c in comparison.changes]
            parts += [f"<p><i>{e(_not_compared(c))}</i></p>" for c in comparison.cautions]
        parts += ["<h2>For the therapist</h2>", rows(content.therapist_header)]
        if content.table:
            heads = ["Figure", "This trial", *content.table_columns, "What it means"]
            parts.append("<table border='1' cellpadding='4' cellspacing='0'><tr>"
                         + "".join(f"<th>{e(h)}</th>" for h in heads) + "</tr>")
            for row in content.table:
                cells = [row.label, f"{row.value_text} {row.unit}".strip(),
                         *row.earlier_texts, row.meaning]
                parts.append("<tr>" + "".join(f"<td>{e(c)}</td>" for c in cells) + "</tr>")
            parts.append("</table>")
        parts += [f"<p><small>{e(n)}</small></p>" for n in content.notes]
        document = QTextDocument()
        document.setHtml("".join(parts))
        return document

    def print_to(self, printer: QPrinter) -> None:
        self.document().print_(printer)

    def print_report(self) -> None:
        if self._content is None:
            return
        printer = QPrinter(QPrinter.PrinterMode.HighResolution)
        dialog = QPrintDialog(printer, self)
        if dialog.exec() == QPrintDialog.DialogCode.Accepted:
            self.print_to(printer)

    def save_pdf(self, path: str | Path) -> None:
        """Write the PDF report (app.reports.build.write_report_pdf) off the GUI thread;
        pdf_saved(path) follows."""
        if self._content is None:
            raise RuntimeError("no report to save yet")
        self.message.setText("Saving the PDF…")
        self.writer.submit(("pdf", Path(path)), write_report_pdf, self._content, Path(path))

    def _choose_pdf(self) -> None:
        if self._content is None:
            return
        suggested = self._content.source.with_suffix(".pdf").name
        if self.pdf_folder:  # the patient's reports in the data folder (ui.main_window)
            suggested = str(Path(self.pdf_folder) / suggested)
        path, _ = QFileDialog.getSaveFileName(self, "Save the report", suggested, "PDF (*.pdf)")
        if path:
            self.save_pdf(path)


SIMULATED = ("Simulated trial: the robot and the patient were the simulator's models, not a "
             "person.")
SEEN_FROM_THE_SEAT = "Seen from your seat, as you sat at the table."
PATH_HEIGHT_PX = 420


def _path_key(figure: PathFigure) -> str:
    within, outside = (label.removeprefix("your hand: ") for label in figure.run_labels)
    key = "grey: the path to follow · ●: the start"
    if figure.runs:
        key += f" · blue: {within} · dashed orange: {outside}"
    return key


def _path_plot(figure: PathFigure) -> pg.PlotWidget:
    """The hand's path as the patient saw it from their seat, as the PDF's page 1 draws it
    (app.reports.pdf_plots.path_plot): the patient sits on +y facing −y (docs/frames.md),
    so both axes reversed, the robot's side at the top; no coordinates, a scale bar."""
    widget = pg.PlotWidget()
    widget.setMinimumHeight(PATH_HEIGHT_PX)
    widget.setBackground("w")
    item = widget.getPlotItem()
    plots.seat_view(item)
    item.setAspectLocked(True)
    outline = figure.outline_m * CM_PER_M
    position = figure.position_m * CM_PER_M
    item.addItem(pg.PlotDataItem(outline[:, 0], outline[:, 1],
                                 pen=pg.mkPen(theme.GRID, width=12)))
    if figure.runs:
        for within, colour, dashed in ((True, theme.WITHIN, False),
                                       (False, theme.OUTSIDE, True)):
            x, y = _runs_of(position, figure.runs, within)
            item.addItem(pg.PlotDataItem(x, y, pen=pg.mkPen(colour, width=2, style=(
                Qt.PenStyle.DashLine if dashed else Qt.PenStyle.SolidLine)),
                connect="finite"))
    else:
        item.addItem(pg.PlotDataItem(position[:, 0], position[:, 1],
                                     pen=pg.mkPen(theme.TEXT, width=2)))
    start = figure.desired_m[0] * CM_PER_M
    item.addItem(pg.ScatterPlotItem([start[0]], [start[1]], size=12,
                                    brush=pg.mkBrush(theme.TEXT), pen=theme.pen(theme.TEXT)))
    low, high = outline.min(axis=0), outline.max(axis=0)
    span = float(max(high - low))
    # the patient's bottom left is the largest x and y (both axes reversed)
    length = next((c for c in (20.0, 10.0, 5.0, 2.0, 1.0) if c <= 0.3 * span), 1.0)
    y_bar = high[1] + 0.12 * span
    item.addItem(pg.PlotDataItem([high[0], high[0] - length], [y_bar, y_bar],
                                 pen=pg.mkPen(theme.TEXT, width=3)))
    for text, x, y, anchor in ((f"{length:g} cm", high[0] - length / 2, y_bar, (0.5, 0.0)),
                               ("the robot's side", (low[0] + high[0]) / 2,
                                low[1] - 0.12 * span, (0.5, 1.0)),
                               ("you sit here", (low[0] + high[0]) / 2,
                                high[1] + 0.25 * span, (0.5, 0.0))):
        label = pg.TextItem(text, color=theme.MUTED, anchor=anchor)
        label.setFont(theme.axis_font())
        label.setPos(x, y)
        item.addItem(label)
    item.setRange(xRange=(low[0] - 0.1 * span, high[0] + 0.1 * span),
                  yRange=(low[1] - 0.3 * span, high[1] + 0.4 * span), padding=0)
    return widget


def _runs_of(position_cm, runs, within: bool):
    """The hand's path with NaN everywhere but the runs of one kind (`within` or not)."""
    x = np.full(len(position_cm), np.nan)
    y = np.full(len(position_cm), np.nan)
    for run in runs:
        if run.within == within:
            part = slice(run.start, run.stop + 1)
            x[part], y[part] = position_cm[part, 0], position_cm[part, 1]
    return x, y


def _which(content: ReportContent) -> str:
    """'session 2, trial 3', or the file's name when the numbers are not known."""
    if content.session_number is None or content.trial_number is None:
        return content.source.name
    return f"session {content.session_number}, trial {content.trial_number}"


def _change_text(change) -> str:
    """'↑ Led the movement: 62 % → 78 %, better', or, when the trials do not compare,
    the numbers alone."""
    return f"{change.arrow} {change.text}" if change.arrow else change.text


def _not_compared(caution: str) -> str:
    """'Not compared: this trial did not run to its end, …' (app.reports.compare)."""
    return f"Not compared: {caution[0].lower()}{caution[1:]}"


def _form(items, problem: str = "") -> QFormLayout:
    form = QFormLayout()
    for item in items:
        value = QLabel(item.value)
        value.setWordWrap(True)
        value.setTextInteractionFlags(Qt.TextInteractionFlag.TextSelectableByMouse)
        if item.label == problem:
            theme.set_role(value, "problem")
        form.addRow(theme.set_role(QLabel(item.label), "caption"), value)
    return form


def _delete_layout(layout) -> None:
    while layout.count():
        item = layout.takeAt(0)
        if item.widget() is not None:
            item.widget().hide()  # gone at once, not at the loop's next pass
            item.widget().deleteLater()
        elif item.layout() is not None:
            _delete_layout(item.layout())


def _texts(layout) -> list[str]:
    texts = []
    for i in range(layout.count()):
        item = layout.itemAt(i)
        widget, inner = item.widget(), item.layout()
        if isinstance(widget, QLabel):
            texts.append(widget.text())
        elif inner is not None:
            texts += _texts(inner)
    return texts
