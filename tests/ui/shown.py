"""A widget as a test of the window's parts sees it: owned by qtbot, at a size, on screen."""

from __future__ import annotations


def shown(qtbot, widget, width: int = 1280, height: int = 800):
    """`widget` given to qtbot (closed after the test), resized, shown, and exposed before
    the test goes on (a hidden or unpainted widget has no geometry to test); returned."""
    qtbot.addWidget(widget)
    widget.resize(width, height)
    widget.show()
    qtbot.waitExposed(widget)
    return widget
