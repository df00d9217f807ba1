"""The Parameters tab's live picture of what can be reached (thesis Figs. A.6–A.7): the
robot's workspace, the arm's comfortable reach around the shoulder, the path with its
unreachable part crossed out, the start, the shoulder and the robot's motors.

It draws a `ui.views.reach.ReachPicture`, computed without Qt; the plot works in
cm, like the Parameters tab's fields.
"""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import QRectF
from PySide6.QtWidgets import QLabel, QVBoxLayout, QWidget

from core.robot import RobotModel
from ui import plots, theme
from ui.views.reach import CM, ReachPicture, robot_workspace


class ReachPreview(QWidget):
    """The plot and its legend; `show_picture` redraws it, `set_flip` mirrors it."""

    def __init__(self, robot: RobotModel, parent=None) -> None:
        super().__init__(parent)
        self.plot = plots.make_plot("x (cm)", "y (cm)")
        item = self.plot.getPlotItem()
        item.setAspectLocked(True)
        mask, (x, y, width, height) = robot_workspace(robot)
        self.workspace = pg.ImageItem(mask.astype(np.uint8))
        # Translucent, so the grid behind it still shows.
        self.workspace.setLookupTable(np.array([[255, 255, 255, 0], [196, 202, 210, 130]],
                                               dtype=np.uint8))
        self.workspace.setRect(QRectF(x * CM, y * CM, width * CM, height * CM))
        self.workspace.setZValue(-10)
        item.addItem(self.workspace, ignoreBounds=True)
        self.reach_far = plots.curve(item, theme.BLUISH_GREEN, dashed=True, xy=True)
        self.reach_near = plots.curve(item, theme.BLUISH_GREEN, dashed=True, xy=True)
        self.path_ok = plots.curve(item, theme.WITHIN, gaps=True, xy=True)
        self.path_out = plots.curve(item, theme.OUTSIDE, dashed=True, gaps=True, xy=True)
        self.path_bad = pg.ScatterPlotItem(symbol="x", size=12, pen=theme.pen(theme.OUTSIDE),
                                           brush=pg.mkBrush(theme.OUTSIDE))
        item.addItem(self.path_bad)
        self.start = pg.ScatterPlotItem(symbol="t1", size=14, pen=theme.pen(theme.BLACK),
                                        brush=pg.mkBrush(theme.BLUE))
        item.addItem(self.start)
        self.shoulder_mark = pg.ScatterPlotItem(symbol="o", size=14, pen=theme.pen(theme.BLACK),
                                                brush=pg.mkBrush(theme.ORANGE))
        item.addItem(self.shoulder_mark)
        self.motors_mark = pg.ScatterPlotItem([0.0], [0.0], symbol="s", size=14,
                                              pen=theme.pen(theme.BLACK),
                                              brush=pg.mkBrush(theme.BLACK))
        item.addItem(self.motors_mark)
        keys = (("#8C9096", "■", "robot can reach"),
                (theme.BLUISH_GREEN, "- - -", "arm reaches comfortably"),
                (theme.WITHIN, "——", "path"), (theme.OUTSIDE, "✕", "cannot be reached"),
                (theme.ORANGE, "●", "shoulder"), (theme.BLACK, "■", "robot motors"),
                (theme.BLUE, "▲", "start"))
        # each key whole on its line (a wrap between "■" and "robot motors" read as two
        # keys); the lines break only between keys
        self.legend = theme.set_role(QLabel("&nbsp;&nbsp; ".join(
            f"<span style='color:{colour}'>{sign.replace(' ', '&nbsp;')}</span>&nbsp;"
            f"{words.replace(' ', '&nbsp;')}" for colour, sign, words in keys)), "caption")
        self.legend.setWordWrap(True)
        layout = QVBoxLayout(self)
        layout.setContentsMargins(0, 0, 0, 0)
        layout.addWidget(self.plot, 1)
        layout.addWidget(self.legend)

    def set_flip(self, flip_x: bool, flip_y: bool) -> None:
        """Mirror the picture like the trajectory tab (display only)."""
        item = self.plot.getPlotItem()
        item.invertX(flip_x)
        item.invertY(flip_y)

    def show_picture(self, picture: ReachPicture | None, shoulder_m: tuple[float, float]) -> None:
        """Draw a check's picture; None (values refused before any check) leaves only the
        shoulder."""
        sx, sy = (v * CM for v in shoulder_m)
        self.shoulder_mark.setData([sx], [sy])
        if picture is None:
            for line in (self.path_ok, self.path_out, self.reach_far, self.reach_near):
                line.setData([], [])
            self.path_bad.setData([], [])
            self.start.setData([], [])
            return
        for line, points in ((self.reach_far, picture.reach_far_cm),
                             (self.reach_near, picture.reach_near_cm),
                             (self.path_ok, picture.reachable_cm),
                             (self.path_out, picture.unreachable_cm)):
            line.setData(points[:, 0], points[:, 1])
        self.path_bad.setData(picture.crosses_cm[:, 0], picture.crosses_cm[:, 1])
        self.start.setData([picture.start_cm[0]], [picture.start_cm[1]])
        self.plot.getPlotItem().setRange(xRange=picture.x_range_cm,
                                         yRange=picture.y_range_cm, padding=0.0)
