"""The entry point explains a missing display instead of a Qt abort."""

import pytest

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


def test_a_font_scale_out_of_range_is_one_line_and_exit_2(capsys, monkeypatch):
    """`rehab gui --font-scale 5` said "internal error … this is a bug" with exit 70: the
    range was checked only by the theme, after the window had begun to start."""
    from ui import theme
    from ui.launcher import FONT_SCALE_RANGE, main

    assert FONT_SCALE_RANGE == theme.FONT_SCALE_RANGE
    monkeypatch.setenv("QT_QPA_PLATFORM", "offscreen")
    for value in ("5", "0.5", "nan", "big"):
        with pytest.raises(SystemExit) as exit_:
            main(["gui", "--font-scale", value])
        assert exit_.value.code == 2
        err = capsys.readouterr().err
        assert err.count("\n") == 1, err
        assert "--font-scale" in err
        assert "from 0.75 to 2" in err
        assert "internal error" not in err
