"""Shared pieces of the tabs: styled plots, curves created once, big numbers, and calls
run off the GUI thread. Which samples they draw is ui.views.samples.

Every curve is a width-1 cosmetic pen with automatic downsampling and clipping to
the view, the settings measured to hold ≥ 50 fps on software rendering
(docs/architecture.md, The window and its Qt stack). Mouse zoom and the context
menu are off: a live clinical display that a brushed sleeve can rescale is worse
than one that always shows the trial.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from concurrent.futures import Future, ThreadPoolExecutor

import pyqtgraph as pg
from PySide6.QtCore import QEvent, QObject, Qt, Signal
from PySide6.QtGui import QFontMetrics
from PySide6.QtWidgets import (
    QFrame,
    QHBoxLayout,
    QLabel,
    QScrollArea,
    QVBoxLayout,
    QWidget,
)

from ui import theme
from ui.views.numbers import format_number


def make_plot(x_label: str, y_label: str, *, title: str = "", parent=None) -> pg.PlotWidget:
    widget = pg.PlotWidget(parent=parent)
    configure_plot(widget.getPlotItem(), x_label, y_label, title=title)
    return widget


def configure_plot(item: pg.PlotItem, x_label: str, y_label: str, *, title: str = "") -> None:
    item.setMenuEnabled(False)
    item.setMouseEnabled(x=False, y=False)
    item.hideButtons()
    item.showGrid(x=True, y=True, alpha=1.0)  # opaque: see theme.GRID
    # The axes draw the grid; pyqtgraph stacks them above the data (z 0.5), so opaque
    # grid lines would cross the curves and markers. Behind the data instead.
    for name in ("left", "bottom", "right", "top"):
        axis = item.getAxis(name)
        axis.setZValue(-1)
        # plain units on every axis: pyqtgraph would rescale small or large values with a
        # prefix of its own ("torque (N·m) (x0.001)" over ticks of ±500, issue 27 #12)
        axis.enableAutoSIPrefix(False)
    item.setLabel("bottom", x_label)
    item.setLabel("left", y_label)
    if title:
        item.setTitle(title)
    theme.register_plot(item)


def seat_view(item: pg.PlotItem) -> None:
    """A still picture of the table as the patient sees it from their seat: no menu, no
    mouse, no axes, both axes reversed (the patient sits on +y facing −y, docs/frames.md:
    the robot's side at the top, the patient's left on the left)."""
    item.setMenuEnabled(False)
    item.setMouseEnabled(x=False, y=False)
    item.hideButtons()
    for name in ("left", "bottom"):
        item.hideAxis(name)
    item.invertX(True)
    item.invertY(True)


def curve(item: pg.PlotItem, colour: str, *, dashed: bool = False, name: str | None = None,
          gaps: bool = False, xy: bool = False) -> pg.PlotDataItem:
    """A curve to feed with setData.

    gaps: the data holds NaN where the line breaks (subsampling keeps NaN; peak
    downsampling would spread them over whole blocks).
    xy: a path in the plane rather than a signal over time. pyqtgraph's clipping and
    automatic downsampling assume increasing x and would cut such a path, so they
    stay off; thin it with `ui.views.samples.xy_step` instead.
    """
    line = pg.PlotDataItem(pen=theme.pen(colour, dashed=dashed), name=name,
                           connect="finite" if gaps else "all")
    # After addItem: PlotItem.addItem overwrites both with its own menu's settings.
    item.addItem(line)
    if not xy:
        line.setDownsampling(auto=True, method="subsample" if gaps else "peak")
        line.setClipToView(True)
    return line


def legend(item: pg.PlotItem) -> pg.LegendItem:
    """The plot's legend on one row above its data, in caption type: inside the data it
    covered the first points of every trial (issue 27 #12, #13). Curves added later with
    a name appear in it (pyqtgraph adds them to `item.legend`)."""
    box = pg.LegendItem(colCount=8, labelTextSize=f"{theme.point_size('caption'):.1f}pt",
                        horSpacing=round(16 * theme.font_scale()), verSpacing=0)
    box.setBrush(pg.mkBrush(None))
    box.setPen(pg.mkPen(None))
    # in the title's row of the plot's grid: these plots have no title
    item.layout.removeItem(item.titleLabel)
    item.titleLabel.hide()
    item.layout.addItem(box, 0, 1)
    height = QFontMetrics(theme.axis_font()).lineSpacing() + round(8 * theme.font_scale())
    item.layout.setRowFixedHeight(0, height)
    item.legend = box
    return box


def joint_curves(item: pg.PlotItem) -> list[pg.PlotDataItem]:
    """A legend and the shoulder (solid blue) and elbow (dashed orange) curves."""
    legend(item)
    return [
        curve(item, theme.BLUE, name="shoulder"),
        curve(item, theme.ORANGE, dashed=True, name="elbow"),
    ]


def label_room(y_label: str, rows: int = 5) -> int:
    """The least height (px) a plot needs for its y label, turned beside the data, with
    `rows` lines of text for the time axis below and a key above: a plot squeezed below
    it cut its label (issue 27 #13)."""
    metrics = QFontMetrics(theme.axis_font())
    return metrics.horizontalAdvance(y_label) + rows * metrics.lineSpacing() + 24


def show_whole(item: pg.PlotItem, time_s) -> None:
    """Show the whole trial on `item`'s time axis (and on the plots linked to it): a plot
    whose x range followed another's data showed the first second of a 12.8 s trial
    (the EMG tab's torques, linked to envelopes of one second, issue 27 #12)."""
    if len(time_s):
        item.setXRange(float(time_s[0]), float(time_s[-1]), padding=0.0)


def cursor_line(item: pg.PlotItem) -> pg.InfiniteLine:
    """The replay cursor on a time axis, hidden until set."""
    line = pg.InfiniteLine(angle=90, movable=False, pen=theme.pen(theme.BLACK, dashed=True))
    line.setZValue(10)
    line.hide()
    item.addItem(line, ignoreBounds=True)
    return line


def place_cursor(line: pg.InfiniteLine, t: float | None) -> None:
    if t is None:
        line.hide()
    else:
        line.setValue(t)
        line.show()


class BigNumber(QWidget):
    """A figure to read from across the room: a caption, a large value with its unit,
    and a line of detail (the range it came from, what it means)."""

    def __init__(self, caption: str, unit: str, *, decimals: int = 1, parent=None) -> None:
        super().__init__(parent)
        self.decimals = decimals
        # A degree sign belongs against the number; set low beside it, it reads as a dot.
        self._degrees = unit == "°"
        self.caption = theme.set_role(QLabel(caption), "caption")
        self.value = theme.set_role(QLabel("–"), "big")
        self.unit = theme.set_role(QLabel("" if self._degrees else unit), "unit")
        self.detail = theme.set_role(QLabel(""), "caption")
        self.detail.setWordWrap(True)
        self.value.setAccessibleName(caption)
        row = QHBoxLayout()
        row.setSpacing(6)
        row.addWidget(self.value)
        row.addWidget(self.unit, 0, Qt.AlignmentFlag.AlignBottom)
        row.addStretch(1)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.setSpacing(0)
        layout.addWidget(self.caption)
        layout.addLayout(row)
        layout.addWidget(self.detail)

    def set_value(self, value: float, detail: str = "") -> None:
        text = format_number(value, self.decimals)
        if self._degrees and text != "–":
            text += "°"
        if self.value.text() != text:
            self.value.setText(text)
        if self.detail.text() != detail:
            self.detail.setText(detail)

    def text(self) -> str:
        return self.value.text()


class Background(QObject):
    """One job at a time off the GUI thread: file reads, filters over a whole trial,
    analyses. The result arrives as a signal in the GUI thread; a job submitted
    while one runs replaces any waiting one (only the newest request matters)."""

    done = Signal(object, object)  # token, result
    failed = Signal(object, str)  # token, message
    _finished = Signal(object, object)  # emitted in the worker; queued to the GUI thread

    def __init__(self, parent: QObject | None = None) -> None:
        super().__init__(parent)
        executor = ThreadPoolExecutor(max_workers=1, thread_name_prefix="ui-background")
        self._executor = executor
        self._running: Future | None = None
        self._waiting: tuple | None = None
        self._finished.connect(self._deliver)
        self.destroyed.connect(lambda *_: executor.shutdown(wait=False, cancel_futures=True))

    @property
    def busy(self) -> bool:
        return self._running is not None

    def submit(self, token: object, function: Callable, *args) -> None:
        if self._running is not None:
            self._waiting = (token, function, args)
            return
        self._start(token, function, args)

    def _start(self, token, function, args) -> None:
        future = self._executor.submit(function, *args)
        self._running = future
        future.add_done_callback(lambda f: self._report(token, f))

    def _report(self, token, future: Future) -> None:
        # RuntimeError: the widget was closed while the job ran, so nobody is listening.
        with contextlib.suppress(RuntimeError):
            self._finished.emit(token, future)

    def _deliver(self, token, future: Future) -> None:
        self._running = None
        if future.cancelled():
            return
        error = future.exception()
        if error is None:
            self.done.emit(token, future.result())
        else:
            self.failed.emit(token, str(error))
        if self._waiting is not None:
            waiting, self._waiting = self._waiting, None
            self._start(*waiting)


def plot_with_panel(owner: QWidget, plot: QWidget, numbers, extras) -> None:
    """The live tabs' layout: the plot on the left, the big numbers and then notes and
    switches in a panel on the right."""
    side = QVBoxLayout()
    for number in numbers:
        side.addWidget(number)
    side.addSpacing(12)
    for widget in extras:
        side.addWidget(widget)
    side.addStretch(1)
    panel = QWidget()
    panel.setLayout(side)
    scroll = vertical_scroll(panel, 300, 420)
    layout = QHBoxLayout(owner)
    layout.addWidget(plot, 1)
    layout.addWidget(scroll)


def vertical_scroll(content: QWidget, min_width: int, max_width: int | None = None
                    ) -> QScrollArea:
    """`content` in an area that scrolls up and down rather than make the window taller
    than a laptop's screen, at least `min_width` (at most `max_width`) wide beside its
    scroll bar, and never narrower than its widest row: nothing is cut at the right, also
    when a row grows later (a label that changes with a choice, a larger font)."""
    scroll = QScrollArea()
    scroll.setWidgetResizable(True)
    scroll.setWidget(content)
    scroll.setFrameShape(QFrame.Shape.NoFrame)
    scroll.setHorizontalScrollBarPolicy(Qt.ScrollBarPolicy.ScrollBarAlwaysOff)
    fit = _FitWidth(scroll, content, min_width, max_width)
    content.installEventFilter(fit)
    fit.fit()
    return scroll


class _FitWidth(QObject):
    """Keeps a vertical scroll area as wide as its content's widest row."""

    def __init__(self, scroll: QScrollArea, content: QWidget, min_width: int,
                 max_width: int | None) -> None:
        super().__init__(scroll)
        self.scroll, self.content = scroll, content
        self.min_width, self.max_width = min_width, max_width

    def fit(self) -> None:
        bar = self.scroll.verticalScrollBar().sizeHint().width()
        widest = self.content.minimumSizeHint().width()
        self.scroll.setMinimumWidth(max(self.min_width, widest) + bar)
        if self.max_width is not None:
            self.scroll.setMaximumWidth(max(self.max_width, widest) + bar)

    def eventFilter(self, watched, event) -> bool:
        if event.type() == QEvent.Type.LayoutRequest:
            self.fit()
        return False
