"""The Progress tab's sizes at the current font (ui.tabs.progress): a plot's least height for
its turned axis title, one left-axis width for both plots, a chooser wide enough for its
longest exercise, and the splitter that asks for its parts' heights as it is resized."""

from __future__ import annotations

import math

from PySide6.QtCore import Qt
from PySide6.QtGui import QFontMetrics
from PySide6.QtWidgets import QComboBox, QSplitter

from ui import theme


def label_least(plot) -> int:
    """The height (px) a plot needs for its left axis's title, drawn turned by 90°, to be
    whole beside the axis: at 1366 × 768 "help (%)" was cut to "elp (" when the table took
    the room. The title's length plus what the plot holds above and below the axis (its
    title, its bottom axis), as the plot lays them out."""
    item = plot.getPlotItem()
    left = item.getAxis("left")
    if not (left.isVisible() and left.labelText):
        return 0
    # the plot's own layout, whatever its height now (before the tab is first shown it is
    # laid out at pyqtgraph's default size): the bottom axis and the margins
    around = max(0, round(item.geometry().height() - left.geometry().height()))
    return math.ceil(left.label.boundingRect().width()) + around + 2


def axis_width() -> int:
    """One width for both plots' left axes, so their trial axes line up: the widest tick
    they draw ('−000.00', a figure's ticks; the help's '100') beside the turned label, at
    the current font (a fixed 60 px laid the label over the ticks at font scale 1.5)."""
    metrics = QFontMetrics(theme.axis_font())
    return (metrics.horizontalAdvance("−000.00") + metrics.height()
            + round(4 * theme.font_scale()) + 8)


def fit_choice(choice: QComboBox) -> None:
    """Wide enough for its longest item at the current font, with room for the arrow: the
    exercises' names must read whole ("As needed · D shape, r 10.0 cm · SMC — 7 trials")."""
    metrics = choice.fontMetrics()
    longest = max((metrics.horizontalAdvance(choice.itemText(i)) for i in range(choice.count())),
                  default=0)
    choice.setMinimumWidth(longest + round(56 * theme.font_scale()))


class Splitter(QSplitter):
    """A vertical splitter that asks for its parts' default heights as it is resized."""

    def __init__(self, fit) -> None:
        super().__init__(Qt.Orientation.Vertical)
        self._fit = fit

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        self._fit()
