"""The patient's screen's words, painted: the top band (the count, the time left), the
bottom's cue or result on one line or two (a game's score beside it), and a session plan's
cover (a rest's countdown, a pause, the end). Each text is rendered once into a pixmap and
kept (the screen redraws the same few words at 60 frames a second); sizes come from
ui.views.patient_geometry (the screen's letter size) and ui.patient.text (what fits)."""

from __future__ import annotations

from PySide6.QtCore import QPointF, QRectF, Qt
from PySide6.QtGui import QColor, QFont, QPainter

from ui.patient.text import fitted_px, margin, qrect, sized, text_pixmap, top_band, two_lines
from ui.views.patient_geometry import LINE_SPACING, Rect, ScreenLayout
from ui.views.patient_plan import PlanOverlay
from ui.views.patient_screen import CUE_DONE, CUE_OVER, CUE_READY, CUE_STOPPED, PatientFrame

BACKGROUND = QColor("#000000")
TEXT = QColor("#FFFFFF")
GO = QColor("#009E73")  # Okabe–Ito bluish green
TEXT_CACHE = 64  # texts kept as pixmaps: the clock's seconds, laps, results


class Words:
    """The screen's texts as pixmaps, made once per text, size, colour and pixel ratio."""

    def __init__(self) -> None:
        self._pixmaps: dict = {}

    def draw(self, painter: QPainter, base: QFont, ratio: float, rect: QRectF,
             align: Qt.AlignmentFlag, text: str, pixel_size: int, colour: QColor,
             backing: bool = False) -> QRectF | None:
        """The text placed in the rect (`base`: the widget's font; `ratio`: its device
        pixel ratio); `backing`: on black, over what is drawn there. Returns where it
        went."""
        if not text:
            return None
        key = (text, pixel_size, colour.rgb(), ratio)
        pixmap = self._pixmaps.get(key)
        if pixmap is None:
            if len(self._pixmaps) > TEXT_CACHE:
                self._pixmaps.clear()
            pixmap = text_pixmap(base, text, pixel_size, colour, ratio)
            self._pixmaps[key] = pixmap
        scale = pixmap.devicePixelRatio()
        width, height = pixmap.width() / scale, pixmap.height() / scale
        if align & Qt.AlignmentFlag.AlignHCenter:
            x = rect.left() + 0.5 * (rect.width() - width)
        elif align & Qt.AlignmentFlag.AlignRight:
            x = rect.right() - width
        else:
            x = rect.left()
        corner = QPointF(x, rect.top() + 0.5 * (rect.height() - height))
        drawn = QRectF(corner.x(), corner.y(), width, height)
        if backing:
            painter.fillRect(drawn, BACKGROUND)
        painter.drawPixmap(corner, pixmap)
        return drawn


def band_font(base: QFont, bands: ScreenLayout) -> QFont:
    font = QFont(base)
    font.setPixelSize(bands.text_px)
    font.setBold(True)
    return font


def paint_words(painter: QPainter, words: Words, base: QFont, ratio: float,
                bands: ScreenLayout, frame: PatientFrame, plan: PlanOverlay | None) -> dict:
    """The top band and the bottom's words of a frame; returns what was painted (for the
    tests that read the screen: the texts, their pixel sizes)."""
    font = band_font(base, bands)
    if plan is not None:
        # a round resumed after a pause: its laps go on ("Lap 3 of 60"), not from 1 of the
        # laps the new trial runs ("Lap 1 of 58", the patient's count gone back)
        frame = frame.counted_on(plan.laps_before)
    # a plan's block is said with "Get ready" (PlanOverlay.ready_text), and a game's score
    # at the bottom (score_beside), not here: beside the lap and the time left either
    # came to 17–19 mm, not 20, full screen on 22 inches
    texts = (frame.repetition_text, "", frame.time_left_text)
    # one size for the band, the largest at which its texts fit side by side
    top, places = top_band(font, bands.top, texts)
    for rect, text, align in zip(places, texts, (Qt.AlignmentFlag.AlignLeft,
                                                 Qt.AlignmentFlag.AlignHCenter,
                                                 Qt.AlignmentFlag.AlignRight), strict=True):
        words.draw(painter, base, ratio, rect, align, text, top, TEXT)
    bottom = qrect(bands.bottom)
    message = frame.message
    if plan is not None and plan.ready_text and frame.cue == CUE_READY:
        message = f"{plan.ready_text}. {message}"  # which block, or which of its rounds
    lines, good = message_lines(font, bottom, frame, message)
    colour = GO if good else TEXT
    rows = [bottom.translated(0, -k * bottom.height()) for k in range(len(lines))][::-1]
    sizes = tuple(min(bands.text_px, fitted_px(font, row, line))
                  for row, line in zip(rows, lines, strict=True))
    if len(rows) > 1:
        # the lines above the band lie over the table's foot: the band grows, on black
        painter.fillRect(QRectF(bottom.left(), rows[0].top(), bottom.width(),
                                bottom.top() - rows[0].top()), BACKGROUND)
    score = frame.game.score_text if frame.game is not None and \
        frame.cue != CUE_STOPPED and not frame.cue.startswith((CUE_DONE, CUE_OVER)) else ""
    beside = score_beside(font, bands.bottom, lines, score)
    if beside is not None:
        rows = [beside[0]]  # the text's own width: centred in it is at its left
        words.draw(painter, base, ratio, beside[1], Qt.AlignmentFlag.AlignRight, score,
                   bands.text_px, TEXT)
    drawn = [words.draw(painter, base, ratio, row, Qt.AlignmentFlag.AlignHCenter, line, size,
                        colour) for row, line, size in zip(rows, lines, sizes, strict=True)]
    figures = paint_figures(painter, words, base, ratio, bands, frame.numbers)
    return {"top": texts, "top_px": top, "score": score if beside is not None else "",
            "message": " ".join(lines),
            "message_lines": lines, "message_px": sizes,
            "message_at": tuple(r for r in drawn if r is not None), "figures_at": figures}


def score_beside(font: QFont, bottom: Rect, lines: tuple[str, ...], score: str
                 ) -> tuple[QRectF, QRectF] | None:
    """Where the bottom's one line and a game's score go side by side at the screen's
    letter size, as the top band's lap and time left above them (the line at the left,
    the score at the right: centred, a hit's "Hit! 0.5 s" was pushed against the score
    and read as one phrase with it), or None: no score, or the line and the score do not
    fit together, the line then said alone ("Keep moving round", which scores nothing)
    and the score back when the line is gone. At the end the cue says the score ("Well
    done! Score 40"), and "Stopped" is said alone.

    The score stood in the top band's middle, beside the lap and the time left: the three
    came to 19.2–19.7 mm, 17.2 with ten laps, full screen on 22 inches, where the screen
    promises 20. The bottom is where the game's results are said, and a hit's "+10" and
    the score's step are then read together."""
    if not score or len(lines) != 1:
        return None
    size, (left, _, right) = top_band(font, bottom, (lines[0], "", score))
    if size < font.pixelSize():
        return None
    return left, right


FIGURES_SHARE = 0.5
"""The figures' letters, a share of the screen's letter size: two lines in the table's
corner beside the exercise (10 mm full screen on 22 inches, read from about 0.75 m)."""


def paint_figures(painter: QPainter, words: Words, base: QFont, ratio: float,
                  bands: ScreenLayout, numbers: tuple[str, ...]) -> tuple[QRectF, ...]:
    """The clinical figures the therapist chose to show (*Show figures to the patient*),
    in the table's top left corner, on black, where the exercise, centred, leaves room:
    they were painted at a third of the letter size over the left of the bottom's words,
    the two unreadable together."""
    if not numbers:
        return ()
    font = sized(band_font(base, bands), max(8, round(FIGURES_SHARE * bands.text_px)))
    area = qrect(bands.table)
    left = bands.top.left + margin(bands.top)  # under the top band's first text
    corner = QRectF(left, area.top(), 0.4 * area.width(), LINE_SPACING * font.pixelSize())
    size = min(fitted_px(font, corner, line) for line in numbers)
    out = []
    for k, line in enumerate(numbers):
        row = corner.translated(0, k * corner.height())
        drawn = words.draw(painter, base, ratio, row, Qt.AlignmentFlag.AlignLeft, line, size,
                           TEXT, backing=True)
        if drawn is not None:
            out.append(drawn)
    return tuple(out)


def message_lines(font: QFont, bottom: QRectF, frame: PatientFrame,
                  message: str) -> tuple[tuple[str, ...], bool]:
    """The bottom's words as lines, and whether they say it went well (green).

    One line, fitted to the width, while the table is watched (a lap under way, the robot
    bringing the hand to the start). When it is not (the trial over, or a task the robot
    leads with the screen blank), words too long for one line at the screen's letter size
    go on two, the first over the table's foot: shrunk to one line, the position task's
    "Relax your arm: the robot moves your hand" came to 14 mm, not 20, full screen on 22
    inches. The end of an exercise gives the last lap's result under its "Well done!" or
    "Finished." (the result was worked out, and never shown: the line held the cue
    alone). A game's outcome during Go! takes its place."""
    if frame.cue == CUE_STOPPED:
        return (CUE_STOPPED,), False  # and nothing else: the therapist explains
    if frame.go and frame.result:
        # a game's first target (1.2 s allowed) is hit or missed under Go!'s 1.5 s: said
        # as it happens, not after Go!, when the hand is on its way to the next
        return (frame.result,), frame.success
    over = frame.cue.startswith((CUE_DONE, CUE_OVER))
    if over and frame.result and frame.game is None:
        # the result itself on two lines if one would shrink it ("Lap 3 over: next time,
        # follow the whole path" came to 13 mm)
        result = (frame.result,) if fitted_px(font, bottom, frame.result) >= \
            font.pixelSize() else two_lines(font, bottom.width(), frame.result)
        return (frame.cue, *(line for line in result if line)), frame.success
    good = frame.go or (not frame.cue and frame.success)
    roomy = over or (frame.blank and frame.push is None)
    if not roomy or fitted_px(font, bottom, message) >= font.pixelSize():
        return (message,), good
    return tuple(line for line in two_lines(font, bottom.width(), message) if line), good


def paint_plan_cover(painter: QPainter, words: Words, base: QFont, ratio: float,
                     bands: ScreenLayout, plan: PlanOverlay) -> dict:
    """A rest, a pause, the end of a plan in place of the table: the block at the top, the
    words and the countdown large, what comes next at the bottom, on two lines when one
    would shrink it below the screen's letter size ("Next: Reaching game, 3 rounds of 6
    targets" came to 95 % of it, edge to edge, full screen on 22 inches), the countdown
    then a line shorter."""
    font = band_font(base, bands)
    # the block where, and as large as, the running screen's top band puts it
    top_px, (top, _, _) = top_band(font, bands.top, (plan.block_text, "", ""))
    words.draw(painter, base, ratio, top, Qt.AlignmentFlag.AlignLeft, plan.block_text, top_px,
               TEXT)
    bottom = qrect(bands.bottom)
    inside = bottom.adjusted(margin(bands.bottom), 0, -margin(bands.bottom), 0)
    lines = (plan.message,)
    if fitted_px(font, inside, plan.message) < font.pixelSize():
        lines = tuple(line for line in two_lines(font, inside.width(), plan.message) if line)
    above = (len(lines) - 1) * bottom.height()  # the lines over the table's foot
    area = qrect(bands.table)
    upper = QRectF(area.left(), area.top(), area.width(), 0.4 * area.height())
    count = QRectF(area.left(), upper.bottom(), area.width(),
                   0.6 * area.height() - above)
    words.draw(painter, base, ratio, upper, Qt.AlignmentFlag.AlignHCenter, plan.centre,
               min(2 * bands.text_px, fitted_px(sized(font, 2 * bands.text_px), upper,
                                                 plan.centre)), TEXT)
    if plan.countdown:
        size = min(int(0.8 * count.height()), 4 * bands.text_px)
        words.draw(painter, base, ratio, count, Qt.AlignmentFlag.AlignHCenter,
                   plan.countdown, fitted_px(sized(font, size), count, plan.countdown), GO)
    rows = [bottom.translated(0, -k * bottom.height()) for k in range(len(lines))][::-1]
    sizes = tuple(fitted_px(font, inside, line) for line in lines)
    for row, line, size in zip(rows, lines, sizes, strict=True):
        words.draw(painter, base, ratio, row, Qt.AlignmentFlag.AlignHCenter, line, size, TEXT)
    return {"top": (plan.block_text, "", ""), "top_px": top_px,
            "plan": (plan.centre, plan.countdown), "plan_lines": lines, "plan_px": sizes}
