"""The Progress tab's scales panel: a robot figure against a clinical scale, over the
patient's sessions or across every patient of the registry (a study), with the
correlation (Pearson, Spearman, n) and, once norms with an MDC95 are in use, the changes
between sessions marked real only beyond it (app.reports.scales_progress). The registry
and the norms are read off the GUI thread.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Signal
from PySide6.QtWidgets import (
    QCheckBox,
    QComboBox,
    QHBoxLayout,
    QLabel,
    QVBoxLayout,
    QWidget,
)

from app.records.scales import value_label
from app.records.store import RecordStore
from app.reports.progress_figure import shown_row, value_span
from app.reports.scales_progress import (
    ScaleSeries,
    figure_keys,
    has_label,
    mdc_text,
    scale_keys,
    scale_series,
    study_series,
)
from core.errors import capitalised
from ui import plots, theme
from ui.fields import ComboBox

REAL_COLOUR = theme.VERMILLION


@dataclass(frozen=True)
class ScalesView:
    """What the panel shows: the choices, the series and the line under it."""

    figures: tuple[str, ...]
    scales: tuple[str, ...]
    series: ScaleSeries | None
    caption: str


def scales_view(registry: RecordStore, code: str, figure: str | None, scale: str | None,
                *, study: bool, include_invalid: bool) -> ScalesView:
    """The panel's content (run off the GUI thread): the figures and scales there are,
    the chosen pair's series (the first of each when the choice is not there) and its
    correlation and MDC line."""
    from app.norms import NormsError
    from app.norms.in_use import norms_in_use

    # the figures the Progress tab offers: a trial's bookkeeping (its duration, a game's
    # hits) named by its key in the list was no figure to set against a scale
    figures = tuple(k for k in figure_keys(registry, code, include_invalid=include_invalid)
                    if has_label(k))
    scales = tuple(scale_keys(registry, None if study else code))
    if not figures or not scales:
        what = "no robot figures yet" if not figures else "no clinical scales recorded yet"
        return ScalesView(figures, scales, None, f"Scales against the robot's figures: {what} "
                          "(record scales on the Registration tab, under Clinical record)")
    figure = figure if figure in figures else figures[0]
    scale = scale if scale in scales else scales[0]
    if study:
        series = study_series(registry, figure, scale, include_invalid=include_invalid)
        return ScalesView(figures, scales, series,
                          f"Study: {series.correlation.text()} ({series.mdc_note})")
    try:
        norms = norms_in_use(registry.data_dir)
        problem = ""
    except NormsError as exc:
        norms, problem = None, f"{theme.PROBLEM_SIGN} the norms could not be read: {exc}"
    series = scale_series(registry, code, figure, scale, include_invalid=include_invalid,
                          norms=norms)
    marks = problem or mdc_text(series, norms)
    return ScalesView(figures, scales, series,
                      f"Over the sessions: {series.correlation.text()}. {capitalised(marks)}")


class ScalesPanel(QWidget):
    """Signals: shown(ScalesView) once a view is drawn."""

    shown = Signal(object)

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self.registry: RecordStore | None = None
        self._code: str | None = None
        self._include_invalid = False
        self._token: tuple | None = None
        self.view: ScalesView | None = None
        self.worker = plots.Background(self)
        self.worker.done.connect(self._loaded)
        self.worker.failed.connect(self._failed)
        self.scale_choice = ComboBox()
        self.scale_choice.setAccessibleName("Clinical scale")
        self.figure_choice = ComboBox()
        self.figure_choice.setAccessibleName("Robot figure against the scale")
        self.study = QCheckBox("Every patient (study)")
        for choice, length in ((self.scale_choice, 14), (self.figure_choice, 18)):
            choice.currentIndexChanged.connect(self._chosen)
            # long labels open wider than the box: the row fits a laptop at a large font
            choice.setSizeAdjustPolicy(
                QComboBox.SizeAdjustPolicy.AdjustToMinimumContentsLengthWithIcon)
            choice.setMinimumContentsLength(length)
        self.study.toggled.connect(self._chosen)
        row = QHBoxLayout()
        row.addWidget(QLabel("Scale"))
        row.addWidget(self.scale_choice)
        row.addSpacing(12)
        row.addWidget(QLabel("against"))
        row.addWidget(self.figure_choice)
        row.addSpacing(12)
        row.addWidget(self.study)
        row.addStretch(1)
        self.plot = plots.make_plot("", "")
        self.caption = theme.set_role(QLabel(""), "caption")
        self.caption.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addLayout(row)
        layout.addWidget(self.caption)
        layout.addWidget(self.plot, 1)

    def set_patient(self, registry: RecordStore | None, code: str | None,
                    include_invalid: bool = False) -> None:
        self.registry, self._code, self._include_invalid = registry, code, include_invalid
        self._load()

    def _chosen(self, *_) -> None:
        self._load()

    def _load(self) -> None:
        if self.registry is None or self._code is None:
            self.view = None
            self._token = None
            self.plot.getPlotItem().clear()
            self.caption.setText("")
            return
        registry, code = self.registry, self._code
        figure, scale = self.figure_choice.currentData(), self.scale_choice.currentData()
        study, include_invalid = self.study.isChecked(), self._include_invalid
        # the token names the request: a late result of an earlier one is not shown
        self._token = (code, figure, scale, study, include_invalid)
        self.worker.submit(self._token, lambda: scales_view(registry, code, figure, scale,
                                                            study=study,
                                                            include_invalid=include_invalid))

    def _failed(self, token, message: str) -> None:
        if token == self._token:
            self.caption.setText(f"{theme.PROBLEM_SIGN} The scales could not be read: "
                                 f"{message}")

    def _loaded(self, token, view: ScalesView) -> None:
        if token != self._token:
            return
        self.view = view
        self._fill(self.figure_choice, view.figures, lambda key: shown_row(key).heading_in_unit,
                   view.series.figure_key if view.series else None)
        self._fill(self.scale_choice, view.scales, value_label,
                   view.series.scale_key if view.series else None)
        self.caption.setText(view.caption)
        self._draw(view.series)
        self.shown.emit(view)

    @staticmethod
    def _fill(choice: ComboBox, keys, label, current) -> None:
        choice.blockSignals(True)
        choice.clear()
        for key in keys:
            choice.addItem(label(key), key)
        index = choice.findData(current)
        choice.setCurrentIndex(index if index >= 0 else 0)
        choice.blockSignals(False)

    def _draw(self, series: ScaleSeries | None) -> None:
        item = self.plot.getPlotItem()
        item.clear()
        theme.style_plot(item)
        # nothing to draw: no empty axes under the caption that says why
        self.plot.setVisible(series is not None and bool(series.points))
        if series is None or not series.points:
            return
        item.setLabel("bottom", series.scale_label)
        item.setLabel("left", series.figure_label)
        factor = series.figure_row.scale
        x = np.array([p.scale for p in series.points])
        y = np.array([p.figure for p in series.points]) * factor
        item.addItem(pg.ScatterPlotItem(x, y, symbol="o", size=11,
                                        pen=theme.pen(theme.BLUE),
                                        brush=pg.mkBrush(theme.BLUE)))
        real = np.array([bool(p.real_change) for p in series.points])
        if real.any():
            # a ring round a session whose change from the one before is beyond the MDC95
            item.addItem(pg.ScatterPlotItem(x[real], y[real], symbol="o", size=22,
                                            pen=pg.mkPen(REAL_COLOUR, width=2),
                                            brush=pg.mkBrush(None)))
        # one session (or sessions alike): pyqtgraph zoomed to the value's last digits
        # ("17.53418183452692"); each axis spans at least its unit's least, as the
        # Progress plots do
        for axis, values, unit in (("x", x, ""), ("y", y, series.figure_row.unit)):
            low, high = value_span(values, unit)
            if low < high:
                item.getViewBox().setRange(**{f"{axis}Range": (low, high)}, padding=0.1)
        study = len({p.code for p in series.points}) > 1
        right = float(x.max())
        for p, px, py in zip(series.points, x, y, strict=True):
            # the label beside its point, towards the plot's inside (never cut at the edge)
            text = pg.TextItem(p.code if study else f"S{p.session_number}", color=theme.TEXT,
                               anchor=(1.0 if px == right and x.size > 1 else 0.0, 1.0))
            text.setFont(theme.axis_font())
            text.setPos(float(px), float(py))
            item.addItem(text)
