"""Where the patient's screen draws the table: the robot's frame turned to the patient's
view, fitted into the screen, and the sizes that keep it readable from the patient's seat.

Everything the console holds is in the robot's global frame (docs/frames.md): the
patient sits on the +y side facing −y, so their right is −x. A screen that stands
beyond the robot, facing the patient, shows the table as the patient sees it when the
screen's right is −x and its up is −y (both axes reversed, as the report's page for the
patient draws it). The options then mirror it left–right (a screen seen in a mirror, or
a setup where the patient's side is the other) and turn it by quarter turns (a screen
turned on its side, or laid flat at the table's end). The frame itself never changes:
`Placement` maps table points (m) to pixels and back, and only the painter uses pixels.

Readable at 1.5 m: a letter's height that a patient with reduced acuity reads without
effort. Normal acuity (Snellen 6/6) resolves letters of 5 arc-minutes; stroke survivors
are mostly older and a share has low vision, so the screen's text is sized well above
that: at least `MIN_LETTER_MM` (20 mm cap height, 46 arc-minutes at 1.5 m, nine times
the 6/6 letter and about the 6/60 line of a chart), when the screen is large enough.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.trajectory import toward_side

VIEWING_DISTANCE_M = 1.5
MIN_LETTER_MM = 20.0
CAP_HEIGHT_PER_PX = 0.7  # a sans-serif's capital is about 0.7 of its pixel size
BAND_SHARE_MAX = 0.14  # at most this share of the screen's height per band of text
LINE_SPACING = 1.3  # a band is a line of text and its leading
MARGIN_SHARE = 0.12  # room around the exercise, a share of its larger side
MIN_MARGIN_M = 0.03
ROTATIONS_DEG = (0, 90, 180, 270)

# The patient's view of the table: screen right = table −x, screen up = table −y.
SEAT_AXES = np.array([[-1.0, 0.0], [0.0, -1.0]])


def screen_axes(mirror: bool, rotation_deg: int) -> np.ndarray:
    """The 2×2 matrix taking table (x, y) to screen (right, up) for the options: the
    patient's view, mirrored left–right if asked, then turned counter-clockwise on the
    screen by `rotation_deg` (a quarter turn)."""
    if rotation_deg not in ROTATIONS_DEG:
        raise ValueError(f"rotation {rotation_deg}° is not a quarter turn: give one of "
                         + ", ".join(str(r) for r in ROTATIONS_DEG))
    axes = SEAT_AXES.copy()
    if mirror:
        axes = np.diag([-1.0, 1.0]) @ axes
    a = math.radians(rotation_deg)
    turn = np.array([[round(math.cos(a)), -round(math.sin(a))],
                     [round(math.sin(a)), round(math.cos(a))]], dtype=float)
    return turn @ axes


def screen_side(side: str, axes: np.ndarray) -> str:
    """Which edge of the screen ("left", "right", "top", "bottom") lies towards the
    patient's `side` ("left" or "right") on the table, as the screen is turned (the
    patient's left is the robot's +x: core.trajectory.toward_side)."""
    right, up = axes @ np.array([toward_side(side), 0.0])
    if abs(right) >= abs(up):
        return "right" if right > 0 else "left"
    return "top" if up > 0 else "bottom"


@dataclass(frozen=True, slots=True)
class Rect:
    """A rectangle in pixels, y down as on every screen."""

    left: float
    top: float
    width: float
    height: float

    @property
    def centre(self) -> tuple[float, float]:
        return (self.left + 0.5 * self.width, self.top + 0.5 * self.height)


@dataclass(frozen=True, slots=True)
class Placement:
    """Table (m, robot frame) to pixels (y down): p_px = origin + s · F · A (p − c), with
    A the screen axes, c the centre of what is shown, s pixels per metre and F = diag(1,
    −1) because a screen's y grows downwards."""

    axes: np.ndarray
    centre_m: tuple[float, float]
    px_per_m: float
    origin_px: tuple[float, float]

    def to_px(self, points_m) -> np.ndarray:
        """Pixels of table points: (2,) → (2,), (N, 2) → (N, 2)."""
        p = np.asarray(points_m, dtype=float)
        u = (p - np.asarray(self.centre_m)) @ self.axes.T
        return np.asarray(self.origin_px) + self.px_per_m * u * np.array([1.0, -1.0])

    def to_table(self, points_px) -> np.ndarray:
        """The table point (m) drawn at pixels; the inverse of `to_px` (A is orthogonal)."""
        q = np.asarray(points_px, dtype=float)
        u = (q - np.asarray(self.origin_px)) * np.array([1.0, -1.0]) / self.px_per_m
        return u @ self.axes + np.asarray(self.centre_m)

    def length_px(self, length_m: float) -> float:
        return self.px_per_m * length_m


def padded_extent(points_m: np.ndarray, pad_m: float = 0.0) -> tuple[float, float, float, float]:
    """(x_min, y_min, x_max, y_max) of the points (m) with a margin around them: the
    larger of `MIN_MARGIN_M`, `MARGIN_SHARE` of the larger side and `pad_m`."""
    p = np.asarray(points_m, dtype=float).reshape(-1, 2)
    low, high = p.min(axis=0), p.max(axis=0)
    margin = max(MIN_MARGIN_M, MARGIN_SHARE * float(np.max(high - low)), pad_m)
    return (float(low[0] - margin), float(low[1] - margin),
            float(high[0] + margin), float(high[1] + margin))


def place(extent_m: tuple[float, float, float, float], axes: np.ndarray, area: Rect) -> Placement:
    """The placement that fits the extent (m), turned by `axes`, whole into `area`, as
    large as it fits and centred, one scale for both axes (the table is not stretched)."""
    x0, y0, x1, y1 = extent_m
    corners = np.array([[x0, y0], [x1, y0], [x0, y1], [x1, y1]]) @ axes.T
    span = corners.max(axis=0) - corners.min(axis=0)
    scale = min(area.width / max(span[0], 1e-6), area.height / max(span[1], 1e-6))
    return Placement(axes, (0.5 * (x0 + x1), 0.5 * (y0 + y1)), float(scale), area.centre)


@dataclass(frozen=True, slots=True)
class ScreenLayout:
    """The screen cut into a band of text at the top (repetitions, time left), the table,
    and a band at the bottom (the start cue, the results); the text's pixel size."""

    top: Rect
    table: Rect
    bottom: Rect
    text_px: int
    letter_mm: float
    """The capitals' height on this screen (mm): below MIN_LETTER_MM the window is too
    small for 1.5 m and the therapist's window says so."""

    @property
    def letter_arcmin(self) -> float:
        """The capitals' height as the patient's eye sees it at VIEWING_DISTANCE_M."""
        return math.degrees(math.atan2(self.letter_mm / 1000.0, VIEWING_DISTANCE_M)) * 60.0

    @property
    def readable(self) -> bool:
        return self.letter_mm >= MIN_LETTER_MM - 1e-9


def layout(width_px: int, height_px: int, mm_per_px: float) -> ScreenLayout:
    """The bands and the text size for a screen of this size and pixel pitch (mm)."""
    if width_px <= 0 or height_px <= 0 or not mm_per_px > 0:
        raise ValueError(f"a screen of {width_px} × {height_px} px at {mm_per_px} mm/px: "
                         "give a positive size and pixel pitch")
    wanted_px = math.ceil(MIN_LETTER_MM / mm_per_px / CAP_HEIGHT_PER_PX)
    text_px = max(8, min(wanted_px, math.floor(BAND_SHARE_MAX * height_px / LINE_SPACING)))
    band = math.ceil(LINE_SPACING * text_px)
    pad = round(0.02 * min(width_px, height_px))
    top = Rect(0, 0, width_px, band)
    bottom = Rect(0, height_px - band, width_px, band)
    table = Rect(pad, band + pad, width_px - 2 * pad, max(1, height_px - 2 * band - 2 * pad))
    return ScreenLayout(top, table, bottom, text_px, text_px * CAP_HEIGHT_PER_PX * mm_per_px)
