"""The console's look: calm, high-contrast, colour-blind safe and large enough to touch.

Colours are the Okabe–Ito palette, which stays distinguishable for the common
colour-vision deficiencies. The one pair that carries meaning everywhere, within
tolerance (blue) and outside (vermillion), also differs in line style (solid and
dashed), so it survives grey-scale printing and every kind of colour blindness.

Sizes follow one font scale (`apply_theme(app, font_scale)`): text, the big
numbers, touch targets and the plots' axis fonts all grow with it, so a clinic
can set the whole window for a patient who reads from two metres away.

pyqtgraph's global options are set here too: white background and antialiasing
on, which was measured to keep ≥ 50 fps with the width-1 cosmetic pens
every curve here uses (wider pens with antialiasing fall to 6–8 fps; docs/architecture.md,
The window and its Qt stack).
"""

from __future__ import annotations

import weakref

import pyqtgraph as pg
import shiboken6
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QFont, QPalette, QPen
from PySide6.QtWidgets import QApplication

# Okabe & Ito (2008), "Color Universal Design".
BLACK = "#000000"
ORANGE = "#E69F00"
SKY_BLUE = "#56B4E9"
BLUISH_GREEN = "#009E73"
YELLOW = "#F0E442"
BLUE = "#0072B2"
VERMILLION = "#D55E00"
REDDISH_PURPLE = "#CC79A7"

WITHIN = BLUE
OUTSIDE = VERMILLION
# Curves of one plot that mean different things (shoulder/elbow, parameter sets).
SERIES = (BLUE, ORANGE, BLUISH_GREEN, REDDISH_PURPLE, SKY_BLUE, VERMILLION, BLACK)
# Scatter symbols paired with SERIES, so a series is told apart without colour.
SYMBOLS = ("o", "s", "t", "d", "+", "x", "star")

TEXT = "#1A1A1A"
MUTED = "#4D4D4D"  # 8.6:1 on white: secondary text stays readable
BACKGROUND = "#FFFFFF"
PANEL = "#F3F5F7"
BORDER = "#7A808A"
# Grid lines are drawn opaque in a light colour, at major ticks only: translucent or
# minor grid lines cost 20–40 ms a repaint on software rendering (7–10× the curves).
GRID = "#D5DAE0"
TARGET = "#6E6E6E"  # the path to follow: present, but quieter than the hand
# Vermillion text on white is only 3.9:1; problem messages use a darker shade of
# it (5.9:1) and always start with a warning sign, so colour is never alone.
PROBLEM_TEXT = "#A33F00"
PROBLEM_SIGN = "⚠"
OK_TEXT = "#006B4F"  # bluish green darkened to 6.1:1

BASE_POINT_SIZE = 12.0
FONT_SCALE_RANGE = (0.75, 2.0)
TOUCH_TARGET_PX = 44  # WCAG 2.5.5 and the platform guidelines agree on ~44 px

# Text roles, set on a label with `set_role(label, role)`; sizes relative to the body.
ROLE_SCALE = {
    "body": 1.0,
    "caption": 0.9,
    "heading": 1.4,
    "lead": 1.6,
    "big": 2.8,
    "unit": 1.3,
    "problem": 1.0,
    "ok": 1.0,
    "banner": 1.2,
}

_state = {"scale": 1.0}
_plots: weakref.WeakSet = weakref.WeakSet()


def font_scale() -> float:
    return _state["scale"]


def point_size(role: str = "body") -> float:
    return BASE_POINT_SIZE * font_scale() * ROLE_SCALE[role]


def touch_px() -> int:
    return round(TOUCH_TARGET_PX * font_scale())


_FUSION_SET = "rehabFusionStyleSet"
"""The application property that says apply_theme has set the Fusion style."""


def apply_theme(app: QApplication, font_scale: float = 1.0) -> None:
    """Apply the look to the whole application; call again to change the font scale."""
    low, high = FONT_SCALE_RANGE
    if not low <= font_scale <= high:
        raise ValueError(f"font scale {font_scale:g} is outside {low:g}–{high:g}")
    _state["scale"] = float(font_scale)
    # Only once per application: QApplication.setStyle deletes the style every widget
    # was polished with and re-polishes them all, and a widget half torn down when that
    # happens (a closed tab's plot awaiting deleteLater) crashed the process in the test
    # suite. Later calls only change the palette, the font and the style sheet.
    if not app.property(_FUSION_SET):
        app.setStyle("Fusion")
        app.setProperty(_FUSION_SET, True)
    app.setPalette(_palette())
    # Fusion outlines check boxes and radio buttons in the window colour darkened by
    # 40 %, which on white is a barely visible grey; a darker "window" for these
    # classes gives an outline of about 4.5:1 (they fill no background with it).
    indicators = _palette()
    indicators.setColor(QPalette.ColorRole.Window, QColor("#A4A9B0"))
    for cls in ("QCheckBox", "QRadioButton"):
        app.setPalette(indicators, cls)
    font = QFont(app.font())
    font.setPointSizeF(point_size())
    app.setFont(font)
    sheet = style_sheet()
    if app.styleSheet() != sheet:
        app.setStyleSheet(sheet)
    pg.setConfigOptions(background=BACKGROUND, foreground=TEXT, antialias=True)
    for plot in list(_plots):
        # A closed window's plot can outlive its C++ object in Python for a while.
        if shiboken6.isValid(plot):
            style_plot(plot)
        else:
            _plots.discard(plot)


def _palette() -> QPalette:
    palette = QPalette()
    colours = {
        QPalette.ColorRole.Window: BACKGROUND,
        QPalette.ColorRole.WindowText: TEXT,
        QPalette.ColorRole.Base: BACKGROUND,
        QPalette.ColorRole.AlternateBase: PANEL,
        QPalette.ColorRole.Text: TEXT,
        QPalette.ColorRole.Button: PANEL,
        QPalette.ColorRole.ButtonText: TEXT,
        QPalette.ColorRole.Highlight: BLUE,
        QPalette.ColorRole.HighlightedText: BACKGROUND,
        QPalette.ColorRole.ToolTipBase: BACKGROUND,
        QPalette.ColorRole.ToolTipText: TEXT,
        QPalette.ColorRole.PlaceholderText: MUTED,
        QPalette.ColorRole.Link: BLUE,
    }
    for role, colour in colours.items():
        palette.setColor(role, QColor(colour))
    palette.setColor(QPalette.ColorGroup.Disabled, QPalette.ColorRole.Text, QColor("#8C8C8C"))
    palette.setColor(QPalette.ColorGroup.Disabled, QPalette.ColorRole.ButtonText,
                     QColor("#8C8C8C"))
    return palette


def style_sheet() -> str:
    """The application style sheet at the current font scale."""
    touch = touch_px()
    pad = round(6 * font_scale())
    roles = "\n".join(
        f'QLabel[role="{role}"] {{ font-size: {point_size(role):.1f}pt; }}' for role in ROLE_SCALE
    )
    return f"""
QWidget {{ color: {TEXT}; }}
QWidget:disabled, QMenu::item:disabled {{ color: #8C8C8C; }}
QPushButton, QToolButton {{
    min-height: {touch}px; padding: 0 {2 * pad}px; border: 1px solid {BORDER};
    border-radius: 6px; background: {PANEL};
}}
QPushButton:hover {{ background: #E6EAEE; }}
QPushButton:pressed {{ background: #D5DBE1; }}
QPushButton:disabled {{ color: #8C8C8C; border-color: #C4C7CC; }}
QPushButton[role="primary"] {{ background: {BLUE}; color: white; border-color: {BLUE}; }}
QPushButton[role="primary"]:disabled {{ background: #9DB9CF; border-color: #9DB9CF; }}
QLineEdit, QAbstractSpinBox, QComboBox {{
    min-height: {touch - 4}px; padding: 0 {pad}px; border: 1px solid {BORDER};
    border-radius: 4px; background: {BACKGROUND};
}}
QLineEdit:focus, QAbstractSpinBox:focus, QComboBox:focus {{ border: 2px solid {BLUE}; }}
QLineEdit:disabled, QAbstractSpinBox:disabled, QComboBox:disabled {{
    background: {PANEL}; color: #8C8C8C; border-color: #C4C7CC;
}}
QAbstractSpinBox::up-button, QAbstractSpinBox::down-button {{ width: {touch * 2 // 3}px; }}
QComboBox::drop-down {{ width: {touch * 2 // 3}px; }}
QCheckBox, QRadioButton {{ min-height: {touch - 8}px; spacing: {pad}px; }}
QCheckBox::indicator, QRadioButton::indicator {{
    width: {round(20 * font_scale())}px; height: {round(20 * font_scale())}px;
}}
QTabBar::tab {{ min-height: {touch}px; padding: 0 {round(1.5 * pad)}px; }}
QGroupBox {{
    font-weight: 600; border: 1px solid #C4C7CC; border-radius: 6px;
    margin-top: {round(point_size() * 1.2)}px; padding-top: {pad}px;
}}
QGroupBox::title {{ subcontrol-origin: margin; left: {pad}px; padding: 0 {pad // 2}px; }}
QListWidget::item, QTableWidget::item {{ min-height: {touch - 8}px; }}
QSlider::groove:horizontal {{ height: {round(8 * font_scale())}px; background: #D5DBE1;
    border-radius: {round(4 * font_scale())}px; }}
QSlider::handle:horizontal {{ width: {touch // 2}px; margin: -{touch // 4}px 0;
    background: {BLUE}; border-radius: {touch // 4}px; }}
{roles}
QLabel[role="big"] {{ font-weight: 600; }}
QLabel[role="heading"] {{ font-weight: 600; }}
QLabel[role="lead"] {{ font-weight: 600; }}
QLabel[role="caption"] {{ color: {MUTED}; }}
QLabel[role="unit"] {{ color: {MUTED}; }}
QLabel[role="problem"] {{ color: {PROBLEM_TEXT}; font-weight: 600; }}
QLabel[role="ok"] {{ color: {OK_TEXT}; }}
QLabel[role="banner"] {{ background: {PANEL}; border: 1px solid #C4C7CC; border-radius: 6px;
    padding: {pad}px; }}
"""


def set_role(widget, role: str):
    """Give a label (or a button: 'primary') its text role; returns the widget."""
    if role not in ROLE_SCALE and role != "primary":
        raise ValueError(f"unknown text role {role!r}; known: {', '.join(ROLE_SCALE)}, primary")
    widget.setProperty("role", role)
    return widget


def switch_role(widget, role: str):
    """Change a shown widget's text role: the style sheet applies only once it is polished
    again."""
    set_role(widget, role)
    widget.style().unpolish(widget)
    widget.style().polish(widget)
    return widget


def pen(colour: str, *, dashed: bool = False) -> QPen:
    """A width-1 cosmetic pen: the only width that keeps live plots ≥ 50 fps (module notes)."""
    qpen = pg.mkPen(colour, width=1)
    qpen.setCosmetic(True)
    if dashed:
        qpen.setStyle(Qt.PenStyle.DashLine)
    return qpen


def within_pen() -> QPen:
    return pen(WITHIN)


def outside_pen() -> QPen:
    return pen(OUTSIDE, dashed=True)


def axis_font() -> QFont:
    font = QFont()
    font.setPointSizeF(point_size("caption"))
    return font


def register_plot(plot_item: pg.PlotItem) -> pg.PlotItem:
    """Style a plot now and again whenever the font scale changes."""
    _plots.add(plot_item)
    style_plot(plot_item)
    return plot_item


def style_plot(plot_item: pg.PlotItem) -> None:
    font = axis_font()
    size = f"{point_size('caption'):.1f}pt"
    for name in ("left", "bottom"):
        axis = plot_item.getAxis(name)
        axis.setStyle(tickFont=font, tickTextOffset=round(4 * font_scale()), maxTickLevel=0)
        axis.setPen(pg.mkPen(GRID))
        axis.setTextPen(pg.mkPen(TEXT))
        if axis.labelText:
            # Units stay inside the label text: pyqtgraph's own units would add SI
            # prefixes (mN, kN·m) a therapist does not expect.
            axis.setLabel(axis.labelText, **{"font-size": size, "color": TEXT})
    if plot_item.titleLabel.text:
        plot_item.setTitle(plot_item.titleLabel.text, size=f"{point_size('body'):.1f}pt",
                           color=TEXT)
