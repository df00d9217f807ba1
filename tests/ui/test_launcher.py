"""The entry point explains a missing display instead of a Qt abort."""

from ui.launcher import display_problem


def test_no_display_is_explained():
    message = display_problem({}, "linux")
    assert "no display" in message
    assert "xvfb-run" in message


def test_display_present_or_offscreen_is_fine():
    assert display_problem({"DISPLAY": ":0"}, "linux") == ""
    assert display_problem({"WAYLAND_DISPLAY": "wayland-0"}, "linux") == ""
    assert display_problem({"QT_QPA_PLATFORM": "offscreen"}, "linux") == ""
    assert display_problem({}, "win32") == ""
