"""Active range: the area of the table the patient's hand reached alone, and its
share of the region both the robot and the arm can reach.

Work area as in Sukal, Ellis & Dewald, Exp Brain Res 183(2):215-223, 2007
(doi:10.1007/s00221-007-1029-6). Our reading of the region reached: the convex
hull of the hand's path (core.assessment.geometry.convex_hull), which fills in
the inside of the outward reaches the patient made; an alpha shape would follow
a non-convex reach more closely but needs a radius nobody has calibrated.

* `range_area_m2`: the hull's area (m²).
* `range_area_ratio`: the area of the hull within the region both the robot and
  the arm can reach, over that region's area (0-1). The region is a polygon the
  caller computes (the battery, from core.robot's and core.arm's reach); it may
  be non-convex.
"""

from __future__ import annotations

from core.assessment.geometry import clip_by_convex, convex_hull, points, signed_area
from core.errors import ParameterError


def range_figures(position_m, reachable_m) -> dict[str, float]:
    """The task's figures keyed as core.assessment.FIGURES from the hand's positions
    (N, 2) m over the task and the reachable region's polygon (M, 2) m, its vertices in
    order (either way round, the last joined to the first)."""
    path = points("position_m", position_m)
    region = points("reachable_m", reachable_m)
    region_area = abs(signed_area(region))
    if len(region) < 3 or region_area <= 0.0:
        raise ParameterError("reachable_m", f"a polygon of {len(region)} vertices and area "
                             f"{region_area:g} m²", "at least 3 vertices enclosing an area")
    hull = convex_hull(path)
    if len(hull) < 3:  # no movement, or along a line: no area
        return {"range_area_m2": 0.0, "range_area_ratio": 0.0}
    inside = clip_by_convex(region, hull)
    shared = abs(signed_area(inside)) if len(inside) >= 3 else 0.0
    # rounding can put the share of a region the hull covers whole a hair above 1
    return {"range_area_m2": signed_area(hull), "range_area_ratio": min(shared / region_area, 1.0)}
