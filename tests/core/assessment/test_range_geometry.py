"""Active range and the plane geometry under it: areas of known squares and their overlap
with known (also non-convex) regions, and the hull, the clip and the longest chord against
brute force on random point sets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings, strategies as st

from core.assessment.active_range import range_figures
from core.assessment.geometry import (
    chord_and_width,
    clip_by_convex,
    convex_hull,
    monotone_chain,
    signed_area,
)
from core.errors import ParameterError


def square_sweep(side, corner=(0.0, 0.3), n=40):
    """A hand path that sweeps a square of `side` m in a zigzag of n rows."""
    rows = []
    for k, y in enumerate(np.linspace(0.0, side, n)):
        xs = np.linspace(0.0, side, n)
        rows.append(np.column_stack([xs if k % 2 == 0 else xs[::-1], np.full(n, y)]))
    return np.vstack(rows) + np.asarray(corner)


def rectangle(x0, y0, x1, y1):
    return np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])


def test_a_square_sweep_and_a_region_half_covered():
    path = square_sweep(0.2)  # the square [0, 0.2] × [0.3, 0.5]
    figures = range_figures(path, rectangle(0.1, 0.3, 0.5, 0.5))  # 0.4 × 0.2, half the square in
    assert figures["range_area_m2"] == pytest.approx(0.04, rel=1e-12)
    assert figures["range_area_ratio"] == pytest.approx(0.1 * 0.2 / (0.4 * 0.2), rel=1e-12)


def test_a_non_convex_region_drawn_clockwise():
    # an L: the square [0, 0.4]² less its top right quarter, listed clockwise
    region = np.array([[0.0, 0.0], [0.0, 0.4], [0.2, 0.4], [0.2, 0.2], [0.4, 0.2],
                       [0.4, 0.0]])
    assert signed_area(region) == pytest.approx(-0.12)
    path = square_sweep(0.3, corner=(0.1, 0.1))  # [0.1, 0.4]²
    figures = range_figures(path, region)
    # inside the L: [0.1, 0.4] × [0.1, 0.2] plus [0.1, 0.2] × [0.2, 0.4]
    assert figures["range_area_ratio"] == pytest.approx((0.3 * 0.1 + 0.1 * 0.2) / 0.12,
                                                        rel=1e-12)
    assert figures["range_area_m2"] == pytest.approx(0.09, rel=1e-12)


def test_a_hand_that_stayed_or_moved_along_a_line_reached_no_area():
    region = rectangle(-0.3, 0.2, 0.3, 0.6)
    assert range_figures(np.tile([0.0, 0.4], (50, 1)), region) == {
        "range_area_m2": 0.0, "range_area_ratio": 0.0}
    line = np.column_stack([np.linspace(-0.1, 0.1, 50), np.full(50, 0.4)])
    assert range_figures(line, region)["range_area_ratio"] == 0.0


def test_a_path_beyond_the_whole_region_counts_it_whole():
    figures = range_figures(square_sweep(1.0, corner=(-0.5, 0.0)), rectangle(-0.3, 0.2, 0.3, 0.6))
    assert figures["range_area_ratio"] == pytest.approx(1.0)
    assert figures["range_area_m2"] == pytest.approx(1.0)


def test_bad_regions_are_refused():
    path = square_sweep(0.2)
    with pytest.raises(ParameterError, match="reachable_m"):
        range_figures(path, [[0.0, 0.0], [1.0, 1.0]])
    with pytest.raises(ParameterError, match="reachable_m"):
        range_figures(path, [[0.0, 0.0], [1.0, 1.0], [2.0, 2.0]])
    with pytest.raises(ParameterError, match="position_m"):
        range_figures(np.full((4, 2), math.nan), rectangle(0, 0, 1, 1))


cloud = st.lists(st.tuples(st.floats(-1, 1), st.floats(-1, 1)), min_size=1, max_size=40)


@settings(max_examples=150, deadline=None)
@given(cloud)
@example([(0.0, 0.625), (1.0, 1.0), (5.0713290655642104e-278, 0.625)])  # CI, 2026-12-05
def test_hull_contains_every_point_and_turns_left(pts):
    pts = np.array(pts)
    hull = convex_hull(pts)
    if len(hull) < 3:
        return
    assert signed_area(hull) > 0.0
    for i in range(len(hull)):
        a, b = hull[i], hull[(i + 1) % len(hull)]
        cross = (b[0] - a[0]) * (pts[:, 1] - a[1]) - (b[1] - a[1]) * (pts[:, 0] - a[0])
        assert (cross >= -1e-12).all()


@settings(max_examples=150, deadline=None)
@given(cloud)
def test_the_longest_chord_is_the_largest_pairwise_distance(pts):
    pts = np.array(pts)
    brute = float(np.sqrt(((pts[:, None] - pts[None]) ** 2).sum(-1)).max())
    chord, width = chord_and_width(pts)
    if brute < 1e-9:
        assert (chord, width) == (0.0, 0.0)
        return
    assert chord == pytest.approx(brute, rel=1e-12)
    assert 0.0 <= width <= chord + 1e-12


@settings(max_examples=100, deadline=None)
@given(cloud, st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(0.05, 1.0))
def test_a_clip_by_a_square_matches_counting_on_a_grid(pts, x0, y0, side):
    hull = convex_hull(np.array(pts))
    if len(hull) < 3:
        return
    box = rectangle(x0, y0, x0 + side, y0 + side)
    area = abs(signed_area(clip_by_convex(box, hull)))
    # the same overlap by counting grid points inside both (a coarse but independent sum)
    g = np.linspace(-1.5, 1.5, 301)
    xx, yy = np.meshgrid(g, g)
    inside_box = (xx >= x0) & (xx <= x0 + side) & (yy >= y0) & (yy <= y0 + side)
    inside_hull = np.ones_like(xx, dtype=bool)
    for i in range(len(hull)):
        a, b = hull[i], hull[(i + 1) % len(hull)]
        inside_hull &= (b[0] - a[0]) * (yy - a[1]) - (b[1] - a[1]) * (xx - a[0]) >= 0.0
    counted = (inside_box & inside_hull).sum() * (g[1] - g[0]) ** 2
    perimeter_band = 4 * (g[1] - g[0]) * (4 * side + 8)  # grid error near both borders
    assert area == pytest.approx(counted, abs=perimeter_band)


@pytest.mark.parametrize("sides", [3, 4, 6, 7, 8, 12, 100])
def test_regular_polygons_parallel_edges_and_all(sides):
    # even polygons have parallel edges (two farthest vertices across each edge)
    angles = np.arange(sides) * 2 * math.pi / sides + 0.3
    corners = np.column_stack([np.cos(angles), np.sin(angles)]) * 0.1 + [0.0, 0.4]
    chord, width = chord_and_width(np.vstack([corners, [[0.0, 0.4]]]))  # the centre inside
    expected = 0.2 if sides % 2 == 0 else 0.2 * math.cos(math.pi / (2 * sides))
    assert chord == pytest.approx(expected, rel=1e-12)
    if sides % 4 == 0:  # a vertex diameter across the first one: the polygon is as wide
        assert width == pytest.approx(0.2, rel=1e-12)
    assert 0.0 < width <= chord * (1 + 1e-12)
    assert len(convex_hull(corners)) == sides
    assert signed_area(convex_hull(corners)) == pytest.approx(
        0.5 * sides * 0.01 * math.sin(2 * math.pi / sides), rel=1e-12)


def test_the_monotone_chain_agrees_with_qhull():
    rng = np.random.default_rng(5)
    for _ in range(50):
        pts = np.unique(rng.normal(size=(int(rng.integers(3, 200)), 2)), axis=0)
        assert signed_area(monotone_chain(pts)) == pytest.approx(
            signed_area(convex_hull(pts)), rel=1e-12)


@settings(max_examples=60, deadline=None)
@given(cloud, st.lists(st.tuples(st.floats(0.1, 1.0), st.floats(0.0, 2 * math.pi)),
                       min_size=3, max_size=12, unique_by=lambda v: round(v[1], 3)))
def test_any_path_and_star_shaped_region_give_a_share_between_0_and_1(pts, star):
    # a star-shaped region (vertices by angle round the origin): simple, maybe non-convex
    star = sorted(star, key=lambda v: v[1])
    region = np.array([[r * math.cos(a), r * math.sin(a)] for r, a in star])
    if abs(signed_area(region)) < 1e-6:
        return
    figures = range_figures(np.array(pts), region)
    assert 0.0 <= figures["range_area_ratio"] <= 1.0
    assert figures["range_area_m2"] >= 0.0
    # the share of the region reached is part of the area reached
    assert figures["range_area_ratio"] * abs(signed_area(region)) <= (
        figures["range_area_m2"] + 1e-12)


def test_a_thin_polygon_far_from_the_origin_keeps_its_area():
    """The shoelace's products of coordinates cancel far from the origin: summed from the
    first vertex, a sliver keeps its area (the plain sum gave 0 for the hull above)."""
    sliver = np.array([(0.0, 0.625), (5e-278, 0.625), (1.0, 1.0)])
    assert signed_area(sliver) == pytest.approx(0.5 * 5e-278 * 0.375, rel=1e-12, abs=0.0)
    square = np.array([(1e6, 1e6), (1e6 + 1e-6, 1e6), (1e6 + 1e-6, 1e6 + 1e-6), (1e6, 1e6 + 1e-6)])
    # its sides as the floats hold them (1e6 + 1e-6 is not a float)
    side_x, side_y = square[1, 0] - square[0, 0], square[2, 1] - square[1, 1]
    assert signed_area(square) == pytest.approx(side_x * side_y, rel=1e-9, abs=0.0)
    assert signed_area(square[::-1]) == pytest.approx(-side_x * side_y, rel=1e-9, abs=0.0)

