"""The entry point explains a missing display instead of a Qt abort."""

from ui.launcher import display_problem


def test_no_display_is_explained():
    message = display_problem({}, "linux")
    assert "no display" in message
    assert "xvfb-run" in message


def test_display_present_or_offscreen_is_fine():
    assert display_problem({"DISPLAY": ":0"}, "linux", lambda name: f"lib{name}.so") == ""
    assert display_problem({"WAYLAND_DISPLAY": "wayland-0"}, "linux") == ""
    assert display_problem({"QT_QPA_PLATFORM": "offscreen"}, "linux") == ""
    assert display_problem({}, "win32") == ""


def test_missing_x_libraries_are_one_line_not_a_qt_abort():
    """Qt 6.5+ aborts the process when libxcb-cursor is missing; the launcher says which
    packages to install instead (a new VM without a desktop had none of them)."""
    have = {"xcb-icccm", "xcb-keysyms"}
    message = display_problem({"DISPLAY": ":99"}, "linux",
                              lambda name: f"lib{name}.so" if name in have else None)
    assert "libxcb-cursor0, libxkbcommon-x11-0" in message
    assert "sudo apt install libxcb-cursor0 libxkbcommon-x11-0" in message
    assert "\n" not in message
