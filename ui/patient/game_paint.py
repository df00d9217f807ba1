"""The games on the patient's screen, painted: the path game's channel, the reaching game's
home, its open target, the target just hit and the distractors (what and where:
ui.views.patient_game, core.games). Colours on black: the channel a dark grey band with
light edges, the target Okabe–Ito yellow, a hit bluish green, distractors reddish purple
crossed out, so no two are told apart by colour alone (the distractor has its cross, the
hit its ring)."""

from __future__ import annotations

from PySide6.QtCore import QPointF, Qt
from PySide6.QtGui import QColor, QPainter, QPainterPath, QPen

from core.games import GameLayout, channel_points
from ui.views.patient_geometry import Placement
from ui.views.patient_screen import PatientFrame

CHANNEL = QColor("#3A3A3A")
CHANNEL_EDGE = QColor("#BFBFBF")
TARGET = QColor("#F0E442")  # Okabe–Ito yellow: the target, and the plain exercise's ring
HIT = QColor("#009E73")
DISTRACTOR = QColor("#CC79A7")
HOME = QColor("#BFBFBF")


def paint_game_layout(painter: QPainter, where: Placement, layout: GameLayout, unit: float,
                      polyline) -> None:
    """What does not move in a game: the path game's channel; the reaching game's home and
    distractors (painted once into the screen's background)."""
    if layout.game == "path":
        _channel(painter, where, layout, unit, polyline)
        return
    home = where.to_px(layout.home_m)
    r_home = where.length_px(0.6 * layout.targets[0].radius_m) if layout.targets else unit
    painter.setPen(_pen(HOME, 0.6 * unit))
    painter.setBrush(Qt.BrushStyle.NoBrush)
    painter.drawEllipse(QPointF(*home), r_home, r_home)
    for disc in layout.distractors:
        centre = where.to_px(disc.centre_m)
        r = where.length_px(disc.radius_m)
        painter.setPen(Qt.PenStyle.NoPen)
        painter.setBrush(DISTRACTOR)
        painter.drawEllipse(QPointF(*centre), r, r)
        painter.setPen(_pen(QColor("#000000"), max(2.0, 0.25 * r)))
        x, y, d = centre[0], centre[1], 0.5 * r
        painter.drawLine(QPointF(x - d, y - d), QPointF(x + d, y + d))
        painter.drawLine(QPointF(x - d, y + d), QPointF(x + d, y - d))


def paint_game_state(painter: QPainter, where: Placement, frame: PatientFrame,
                     unit: float) -> tuple[float, float] | None:
    """The game now: the target just hit, the open target; returns the open target's
    centre (px), if any."""
    game = frame.game
    if game is None:
        return None
    if game.hit_target is not None:
        centre = where.to_px(game.hit_target.centre_m)
        r = where.length_px(game.hit_target.radius_m)
        painter.setPen(_pen(HIT, unit))
        painter.setBrush(HIT)
        painter.drawEllipse(QPointF(*centre), r, r)
        painter.setBrush(Qt.BrushStyle.NoBrush)
        painter.drawEllipse(QPointF(*centre), 1.5 * r, 1.5 * r)
    if game.open_target is None:
        return None
    centre = where.to_px(game.open_target.centre_m)
    r = where.length_px(game.open_target.radius_m)
    painter.setPen(Qt.PenStyle.NoPen)
    painter.setBrush(TARGET)
    painter.drawEllipse(QPointF(*centre), r, r)
    return (float(centre[0]), float(centre[1]))


def _channel(painter: QPainter, where: Placement, layout: GameLayout, unit: float,
             polyline) -> None:
    points = where.to_px(channel_points(layout, 0.004))
    path: QPainterPath = polyline(points)
    width = 2.0 * where.length_px(layout.channel_half_width_m)
    painter.setBrush(Qt.BrushStyle.NoBrush)
    # the edges: a light band a little wider, the channel's dark band over it
    painter.setPen(_pen(CHANNEL_EDGE, width + unit))
    painter.drawPath(path)
    painter.setPen(_pen(CHANNEL, width - unit))
    painter.drawPath(path)
    start = points[0]
    painter.setPen(_pen(HOME, 0.5 * unit))
    painter.drawEllipse(QPointF(*start), 0.5 * width, 0.5 * width)


def _pen(colour: QColor, width: float) -> QPen:
    pen = QPen(colour, width)
    pen.setCapStyle(Qt.PenCapStyle.RoundCap)
    pen.setJoinStyle(Qt.PenJoinStyle.RoundJoin)
    return pen

