"""The patient's window: a second top-level window that only paints.

What it shows and where come from `ui.views.patient_screen` (the content at a moment)
and `ui.views.patient_geometry` (the patient's view of the table, the text's size); this
widget paints them with QPainter, nothing else. It never takes the keyboard: the window
is flagged not to accept focus and is shown without activating, so Esc and Space (the
emergency stop) keep going to the therapist's window, and they are application-wide
shortcuts there anyway (ui.window.fault_latch).

Colours: white and the Okabe–Ito yellow and sky blue on black, contrast 21:1, 19:1 and
10:1 (WCAG's AAA asks 7:1), for a patient reading from across the table.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
from PySide6.QtCore import QPointF, QRectF, Qt, Signal
from PySide6.QtGui import (
    QColor,
    QFont,
    QGuiApplication,
    QPainter,
    QPainterPath,
    QPen,
    QPixmap,
)
from PySide6.QtWidgets import QWidget

from ui.patient.game_paint import TARGET, paint_game_layout, paint_game_state
from ui.patient.sound import Tone
from ui.patient.text import margin, qrect
from ui.patient.words import BACKGROUND, GO, Words, paint_plan_cover, paint_words
from ui.views.patient_game import GameFeed
from ui.views.patient_geometry import (
    MIN_LETTER_MM,
    Placement,
    Rect,
    ScreenLayout,
    layout,
    place,
    screen_axes,
    screen_side,
)
from ui.views.patient_plan import PlanOverlay, overlay
from ui.views.patient_screen import (
    CUE_STOPPED,
    PatientFrame,
    PatientOptions,
    Scene,
    frame_at,
    waiting_frame,
)
from ui.views.trialview import TrialView

PATH = QColor("#BFBFBF")
CURSOR = QColor("#56B4E9")  # Okabe–Ito sky blue
PREVIOUS = QColor("#56B4E9")  # the cursor's sky blue, dashed
OUTSIDE = QColor("#D55E00")  # Okabe–Ito vermillion: the ball outside the channel
PROGRESS_LEFT = QColor("#3A3A3A")
ATTENTION = QColor("#E69F00")  # Okabe–Ito orange: the neglected side
MM_PER_INCH = 25.4


class PatientWindow(QWidget):
    """The patient's screen. Feed it with `show_view(view, parameters)` (live, from the
    window's repaint timer) or `show_parameters(parameters)` (no trial running).

    Signals: closed() when it closes (by the patient's window manager or the console).
    `painted` holds what the last paint drew in pixels (the cursor, the target), for the
    tests that compare it with the trial file."""

    closed = Signal()
    size_said = Signal(str, bool)
    """(words, too small) when the letters' height crosses MIN_LETTER_MM as the window is
    resized or moved to another screen: the therapist is told, once each way."""

    def __init__(self, options: PatientOptions | None = None) -> None:
        super().__init__(None, Qt.WindowType.Window | Qt.WindowType.WindowDoesNotAcceptFocus)
        self.setWindowTitle("Patient's screen")
        self.setAttribute(Qt.WidgetAttribute.WA_ShowWithoutActivating)
        self.setFocusPolicy(Qt.FocusPolicy.NoFocus)
        self.setAttribute(Qt.WidgetAttribute.WA_OpaquePaintEvent)
        self.setMinimumSize(320, 240)
        self.options = options or PatientOptions()
        self.scene: Scene | None = None
        self.game_feed: GameFeed | None = None
        self.tone: Tone | None = None  # made when the sound is first wanted
        self._heard: tuple = ((None, None), 0)  # (view, Go's time) the Go was played for, hits
        self.frame: PatientFrame = waiting_frame(None)
        self.painted: dict[str, tuple[float, float] | None] = {}
        self.paints = 0
        self._shown_state: tuple = ()
        self._cached_background: tuple | None = None
        self._attention: str | None = None
        self._words = Words()
        self.plan: PlanOverlay | None = None  # the session plan's part, while one runs
        self._readable: bool | None = None  # the letters were readable at 1.5 m, when known

    # -- content ------------------------------------------------------------------
    def set_options(self, options: PatientOptions) -> None:
        self.options = options
        self._shown_state = ()
        self.update()

    def show_plan(self, state, laps: float = 0.0, shown: float = 0.0) -> None:
        """The session plan's state (app.plans.runner.PlanState), or None without a plan:
        the block, the session's progress, the rest's countdown. `laps`: the running
        trial's laps passed (ui.views.patient_plan.laps_passed); `shown`: the bar this
        run showed last, which it never goes below."""
        plan = overlay(state, laps)
        if plan is not None:
            plan = plan.at_least(shown)
        if plan != self.plan:
            self.plan = plan
            self.update()

    def show_parameters(self, parameters, stopped: bool = False) -> None:
        """No trial running: the exercise to come (or nothing); `stopped` as in
        show_view."""
        self._set_scene(parameters)
        frame = stopped_frame(waiting_frame(self.scene), stopped)
        state = ("wait", id(self.scene), stopped)
        if state != self._shown_state:
            self._shown_state = state
            self.frame = frame
            self.update()

    def show_view(self, view: TrialView, exercise_start_s: float | None = None,
                  stopped: bool = False) -> None:
        """The trial at the view's current sample; repaints only when that changed.
        `exercise_start_s`: the exercise's start as the loop said it, live (frame_at).
        `stopped`: the console's e-stop or a fault is latched (ui.views.latch): "Stopped"
        at once, not when the loop's first faulted record reaches the view (0.4 s later
        on the development VM, the motors already off)."""
        if view.parameters is None:
            self.show_parameters(None, stopped)
            return
        self._set_scene(view.parameters)
        state = (id(view), view.n, view.current_index, view.finished, stopped)
        if state == self._shown_state:
            return
        self._shown_state = state
        self.frame = stopped_frame(frame_at(view, self.scene, self.options, self.game_feed,
                                            exercise_start_s), stopped)
        if view.cursor is None:  # live: a replay is silent
            self._sound(view, self.frame)
        self.update()

    def _sound(self, view: TrialView, frame: PatientFrame) -> None:
        """The tone once at each trial's Go, and on each new hit (or clean lap)."""
        if not self.options.sound:
            return
        if self.tone is None:
            self.tone = Tone()
        if frame.go and self._heard[0] != (id(view), frame.exercise_started_s):
            self._heard = ((id(view), frame.exercise_started_s), 0)
            self.tone.play("go")
        if frame.game is not None and self._heard[0][0] == id(view):
            hits = frame.game.state.hits
            if hits > self._heard[1]:
                self._heard = (self._heard[0], hits)
                self.tone.play("hit")

    def _set_scene(self, parameters) -> None:
        if parameters is None:
            self.scene = self.game_feed = None
        elif self.scene is None or self.scene.parameters != parameters:
            self.scene = Scene.of(parameters)
            self.game_feed = GameFeed(self.scene.game) if self.scene.game else None

    # -- geometry -----------------------------------------------------------------
    def mm_per_px(self) -> float:
        screen = self.screen() or QGuiApplication.primaryScreen()
        dpi = screen.physicalDotsPerInchY() if screen is not None else 96.0
        return MM_PER_INCH / (dpi if dpi and dpi > 0 else 96.0)

    def screen_layout(self) -> ScreenLayout:
        return layout(self.width(), self.height(), self.mm_per_px())

    def placement(self) -> Placement | None:
        if self.scene is None:
            return None
        axes = screen_axes(self.options.mirror, self.options.rotation_deg)
        return place(self.scene.extent_m, axes, self.screen_layout().table)

    # -- painting -----------------------------------------------------------------
    # What does not move (the black, the path or the game's layout, the neglect cue, the
    # last lap's path) is painted once into a background pixmap, and each text once into
    # its own: a frame then costs a copy and a few discs (bench/patient_screen.py).
    def paintEvent(self, _event) -> None:
        bands = self.screen_layout()
        where = self.placement()
        frame = self.frame
        painter = QPainter(self)
        plan = self.plan
        if plan is not None and plan.covers_table:
            # a rest, a pause, the end: the words and the countdown in place of the table
            painter.fillRect(self.rect(), BACKGROUND)
            self.painted = {"cursor": None, "target": None, "attention": None}
            self.painted.update(paint_plan_cover(painter, self._words, self.font(),
                                                 self.devicePixelRatioF(), bands, plan))
        else:
            painter.drawPixmap(0, 0, self._background(bands, where, frame))
            self.painted = {"cursor": None, "target": None, "attention": self._attention}
            painter.setRenderHint(QPainter.RenderHint.Antialiasing)
            if where is not None:
                self._paint_moving(painter, where, frame)
            self.painted.update(paint_words(painter, self._words, self.font(),
                                            self.devicePixelRatioF(), bands, frame, self.plan))
        if plan is not None:
            self._paint_progress(painter, bands, plan)
        painter.end()
        self.paints += 1

    def _paint_progress(self, painter: QPainter, bands: ScreenLayout,
                        plan: PlanOverlay) -> None:
        """The session's exercise done, a bar under the top band."""
        if plan.progress != plan.progress:  # NaN: nothing planned to count
            return
        height = max(6.0, 0.012 * self.height())
        left = bands.top.left + margin(bands.top)
        bar = QRectF(left, bands.top.height, self.width() - 2 * left, height)
        painter.fillRect(bar, PROGRESS_LEFT)
        done = QRectF(bar.left(), bar.top(), bar.width() * min(1.0, plan.progress), height)
        painter.fillRect(done, CURSOR)
        self.painted["progress"] = done.width() / bar.width()

    def _background(self, bands: ScreenLayout, where: Placement | None,
                    frame: PatientFrame) -> QPixmap:
        previous = frame.previous_path_m is not None
        key = (self.width(), self.height(), self.devicePixelRatioF(), id(self.scene),
               self.options, (frame.exercise_started_s, frame.repetition) if previous else None,
               frame.blank)
        if self._cached_background is not None and self._cached_background[0] == key:
            return self._cached_background[1]
        ratio = self.devicePixelRatioF()
        pixmap = QPixmap(round(self.width() * ratio), round(self.height() * ratio))
        pixmap.setDevicePixelRatio(ratio)
        pixmap.fill(BACKGROUND)
        self._attention = None
        if where is not None:
            painter = QPainter(pixmap)
            painter.setRenderHint(QPainter.RenderHint.Antialiasing)
            if self.scene.parameters.neglect_side:
                self._paint_attention(painter, where, bands.table)
            unit = self._unit(where)
            if frame.blank:
                pass  # a task the robot leads: nothing of the layout on the table
            elif self.scene.game is not None:
                paint_game_layout(painter, where, self.scene.game, unit, _polyline)
            else:
                self._paint_exercise(painter, where, unit)
            if previous:
                # the hand's own colour, dashed: where the hand went, not where to go
                pen = _pen(PREVIOUS, unit * 0.6)
                pen.setStyle(Qt.PenStyle.DashLine)
                painter.setPen(pen)
                painter.drawPath(_polyline(where.to_px(frame.previous_path_m)))
            painter.end()
        self._cached_background = (key, pixmap)
        return pixmap

    @staticmethod
    def _unit(where: Placement) -> float:
        return max(2.0, where.length_px(0.004))  # a 4 mm line on the table

    def _paint_moving(self, painter: QPainter, where: Placement, frame: PatientFrame) -> None:
        scene = self.scene
        unit = self._unit(where)
        if frame.blank:
            if frame.push is not None:
                self._paint_push(painter, where, frame.push, unit)
            return
        radius = where.length_px(scene.target_radius_m)
        if scene.game is not None:
            self.painted["target"] = paint_game_state(painter, where, frame, unit)
        elif 0 <= frame.active_target < len(scene.targets_m):
            painter.setPen(_pen(TARGET, unit * 0.6))
            painter.setBrush(TARGET)
            centre = where.to_px(scene.targets_m[frame.active_target])
            painter.drawEllipse(QPointF(*centre), radius, radius)
        if frame.go:
            # the start cue on the table too: a green ring round the start
            painter.setPen(_pen(GO, unit))
            painter.setBrush(Qt.BrushStyle.NoBrush)
            painter.drawEllipse(QPointF(*where.to_px(scene.start_m)), 2 * radius, 2 * radius)
        if frame.target_m is not None:
            point = where.to_px(frame.target_m)
            painter.setPen(_pen(TARGET, unit * 0.6))
            painter.setBrush(Qt.BrushStyle.NoBrush)
            painter.drawEllipse(QPointF(*point), radius, radius)
            self.painted["target"] = (float(point[0]), float(point[1]))
        if frame.cursor_m is not None:
            point = where.to_px(frame.cursor_m)
            painter.setPen(Qt.PenStyle.NoPen)
            outside = frame.game is not None and not frame.game.state.inside
            painter.setBrush(OUTSIDE if outside else CURSOR)
            # the ball: never larger than the channel it must keep inside
            ball = 0.6 * radius if scene.game is None or scene.game.game != "path" else \
                0.8 * where.length_px(scene.game.channel_half_width_m)
            painter.drawEllipse(QPointF(*point), ball, ball)
            self.painted["cursor"] = (float(point[0]), float(point[1]))

    def _paint_push(self, painter: QPainter, where: Placement,
                    push: tuple[float, float, float], unit: float) -> None:
        """Strength: the arrow of the push from the centre (the layout's radius long), a
        bar along it growing with the force pushed, full at the line, and the line itself
        across the arrow's end (core.control.hold: what the robot can hold there)."""
        angle, line_N, force_N = push
        centre = np.asarray(self.scene.parameters.centre_m, dtype=float)
        u = np.array([math.cos(angle), math.sin(angle)])
        length = self.scene.parameters.radius_m
        tip = centre + length * u
        painter.setPen(_pen(PATH, unit))
        painter.drawLine(QPointF(*where.to_px(centre)), QPointF(*where.to_px(tip)))
        side = 0.25 * length * np.array([-u[1], u[0]])
        for wing in (side, -side):
            painter.drawLine(QPointF(*where.to_px(tip)),
                             QPointF(*where.to_px(tip - 0.3 * length * u + wing)))
        share = min(max(force_N / line_N, 0.0), 1.2) if line_N > 0 else 0.0
        if share > 0.0:
            painter.setPen(_pen(GO, 3 * unit))
            painter.drawLine(QPointF(*where.to_px(centre)),
                             QPointF(*where.to_px(centre + share * length * u)))
        painter.setPen(_pen(TARGET, 1.5 * unit))
        painter.drawLine(QPointF(*where.to_px(tip + 0.8 * side)),
                         QPointF(*where.to_px(tip - 0.8 * side)))
        self.painted["target"] = tuple(float(v) for v in where.to_px(tip))

    def _paint_attention(self, painter: QPainter, where: Placement, area: Rect) -> None:
        """Hemispatial neglect (the trial's `neglect_side`): a bright band with arrows along
        the table's edge on the patient's neglected side, to draw the eyes there (visual
        cueing toward the neglected hemispace, Pedroli et al. 2015, doi
        10.3389/fnbeh.2015.00226), where the trial's targets are turned."""
        edge = screen_side(self.scene.parameters.neglect_side, where.axes)
        thick = max(6.0, 0.025 * min(area.width, area.height))
        r = qrect(area)
        band = {"left": QRectF(r.left(), r.top(), thick, r.height()),
                "right": QRectF(r.right() - thick, r.top(), thick, r.height()),
                "top": QRectF(r.left(), r.top(), r.width(), thick),
                "bottom": QRectF(r.left(), r.bottom() - thick, r.width(), thick)}[edge]
        painter.fillRect(band, ATTENTION)
        arrow = {"left": "◀", "right": "▶", "top": "▲", "bottom": "▼"}[edge]
        font = QFont(self.font())
        font.setPixelSize(int(3 * thick))
        painter.setFont(font)
        painter.setPen(ATTENTION)
        inner = r.adjusted(thick * 1.5, thick * 1.5, -thick * 1.5, -thick * 1.5)
        align = {"left": Qt.AlignmentFlag.AlignLeft, "right": Qt.AlignmentFlag.AlignRight,
                 "top": Qt.AlignmentFlag.AlignTop, "bottom": Qt.AlignmentFlag.AlignBottom}[edge]
        cross = (Qt.AlignmentFlag.AlignVCenter if edge in ("left", "right")
                 else Qt.AlignmentFlag.AlignHCenter)
        painter.drawText(inner, align | cross, arrow)
        self._attention = edge

    def _paint_exercise(self, painter: QPainter, where: Placement, unit: float) -> None:
        """An exercise that is not a game: the path, or the reach targets (the one the
        robot's reference moves to is lit over them, _paint_moving)."""
        scene = self.scene
        painter.setPen(_pen(PATH, unit))
        if len(scene.targets_m):
            home = where.to_px(scene.parameters.centre_m)
            for target in scene.targets_m:
                end = where.to_px(target)
                painter.drawLine(QPointF(*home), QPointF(*end))
        else:
            painter.drawPath(_polyline(where.to_px(scene.path_m)))
        radius = where.length_px(scene.target_radius_m)
        painter.setPen(_pen(PATH, unit * 0.6))
        painter.setBrush(Qt.BrushStyle.NoBrush)
        for target in scene.targets_m:
            painter.drawEllipse(QPointF(*where.to_px(target)), radius, radius)

    def resizeEvent(self, event) -> None:
        super().resizeEvent(event)
        self._check_size()

    def _check_size(self) -> None:
        bands = self.screen_layout()
        if bands.readable == self._readable:
            return
        self._readable = bands.readable
        if bands.readable:
            self.size_said.emit(f"The patient's screen's letters are {bands.letter_mm:.0f} mm "
                                "high: readable from 1.5 m.", False)
        else:
            self.size_said.emit(
                f"The patient's screen's letters are only {bands.letter_mm:.0f} mm high, too "
                f"small to read from 1.5 m (give {MIN_LETTER_MM:.0f} mm): put it full screen "
                "(F11) or on a larger monitor.", True)

    def closeEvent(self, event) -> None:
        if self.tone is not None:
            self.tone.close()
            self.tone = None
        super().closeEvent(event)
        self.closed.emit()


def stopped_frame(frame: PatientFrame, stopped: bool) -> PatientFrame:
    """The frame with "Stopped" for its cue while the e-stop or a fault is latched: no Go,
    no result, no praise (the therapist explains, ui.views.patient_screen)."""
    if not stopped or frame.cue == CUE_STOPPED:
        return frame
    return dataclasses.replace(frame, cue=CUE_STOPPED, go=False, result="", success=False)


def _pen(colour: QColor, width: float) -> QPen:
    pen = QPen(colour, width)
    pen.setCapStyle(Qt.PenCapStyle.RoundCap)
    pen.setJoinStyle(Qt.PenJoinStyle.RoundJoin)
    return pen


def _polyline(points: np.ndarray) -> QPainterPath:
    path = QPainterPath()
    finite = np.isfinite(points).all(axis=1)
    drawing = False
    for (x, y), ok in zip(points, finite, strict=True):
        if not ok:
            drawing = False
        elif drawing:
            path.lineTo(x, y)
        else:
            path.moveTo(x, y)
            drawing = True
    return path
