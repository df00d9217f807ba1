"""The patient's view of the table (ui.views.patient_geometry): the robot frame stays
inside, the screen shows it as the patient sees it, turned and mirrored as asked, whole,
and its text is large enough for 1.5 m when the screen is."""

import math

import numpy as np
import pytest
from hypothesis import given, strategies as st

from ui.views.patient_geometry import (
    MIN_LETTER_MM,
    Rect,
    layout,
    padded_extent,
    place,
    screen_axes,
)

rotations = st.sampled_from((0, 90, 180, 270))
coordinate = st.floats(-0.6, 0.6)
points = st.lists(st.tuples(coordinate, coordinate), min_size=2, max_size=30)
sizes = st.tuples(st.integers(320, 3840), st.integers(240, 2160))


@given(points, st.booleans(), rotations, sizes)
def test_every_point_shown_is_inside_the_table_area_and_maps_back(pts, mirror, turn, size):
    p = np.array(pts)
    area = layout(*size, 0.25).table
    where = place(padded_extent(p), screen_axes(mirror, turn), area)
    px = where.to_px(p)
    tol = 1e-6 * max(size)
    assert (px[:, 0] >= area.left - tol).all()
    assert (px[:, 0] <= area.left + area.width + tol).all()
    assert (px[:, 1] >= area.top - tol).all()
    assert (px[:, 1] <= area.top + area.height + tol).all()
    np.testing.assert_allclose(where.to_table(px), p, atol=1e-9)


@given(st.booleans(), rotations)
def test_the_picture_is_never_stretched(mirror, turn):
    axes = screen_axes(mirror, turn)
    np.testing.assert_allclose(axes @ axes.T, np.eye(2), atol=1e-12)
    # mirrored or not, one scale: a 10 cm step is as long on the screen whichever way
    where = place((-0.5, 0.1, -0.1, 0.5), axes, Rect(0, 0, 800, 600))
    for step in ((0.1, 0.0), (0.0, 0.1), (0.06, 0.08)):
        a, b = where.to_px([(-0.3, 0.3), (-0.3 + step[0], 0.3 + step[1])])
        assert math.hypot(*(b - a)) == pytest.approx(0.1 * where.px_per_m)


def test_the_patient_sees_their_right_on_the_right_and_the_far_side_up():
    """The patient sits on +y facing −y: their right is −x (docs/frames.md)."""
    where = place((-0.5, 0.1, -0.1, 0.5), screen_axes(False, 0), Rect(0, 0, 800, 600))
    centre = np.array([-0.3, 0.3])
    right_of_patient = where.to_px(centre + np.array([-0.1, 0.0])) - where.to_px(centre)
    farther_away = where.to_px(centre + np.array([0.0, -0.1])) - where.to_px(centre)
    assert right_of_patient[0] > 0
    assert right_of_patient[1] == pytest.approx(0)
    assert farther_away[1] < 0
    assert farther_away[0] == pytest.approx(0)
    mirrored = place((-0.5, 0.1, -0.1, 0.5), screen_axes(True, 0), Rect(0, 0, 800, 600))
    assert (mirrored.to_px(centre + np.array([-0.1, 0.0])) - mirrored.to_px(centre))[0] < 0
    turned = place((-0.5, 0.1, -0.1, 0.5), screen_axes(False, 90), Rect(0, 0, 800, 600))
    # a quarter turn anticlockwise: the patient's right now points up the screen
    assert (turned.to_px(centre + np.array([-0.1, 0.0])) - turned.to_px(centre))[1] < 0


def test_a_rotation_that_is_not_a_quarter_turn_is_refused():
    with pytest.raises(ValueError, match="rotation 45° is not a quarter turn"):
        screen_axes(False, 45)


def test_text_is_readable_at_1_5_m_on_a_monitor_and_said_when_the_window_is_too_small():
    # a 24-inch 1920 × 1080 monitor: 0.277 mm a pixel
    big = layout(1920, 1080, 0.277)
    assert big.readable
    assert big.letter_mm >= MIN_LETTER_MM
    assert big.letter_arcmin > 40  # eight times the 5' letter of normal acuity
    assert big.top.height + big.bottom.height < 0.3 * 1080  # the table keeps most
    small = layout(640, 360, 0.277)
    assert not small.readable
    assert small.letter_mm < MIN_LETTER_MM
    with pytest.raises(ValueError, match="give a positive size"):
        layout(0, 100, 0.25)
