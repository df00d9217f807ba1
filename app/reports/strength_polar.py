"""The isometric strength task's polar plot on its PDF page (the issue's "peak and mean
force per direction as a polar plot"): the peak and the mean force along each push
direction as two closed polygons (core.assessment.strength.strength_polar,
closed_outline), the line the patient was shown (the robot's limit there) dashed when the
trial's parameters are known, seen from the patient's seat (SEEN_FROM_SEAT_RAD: the
robot's side at the top), each direction named as the patient would say it.
"""

from __future__ import annotations

import math

from app.reports.pdf_sheet import BLUE, GREY, VERMILLION
from core.assessment.strength import SEEN_FROM_SEAT_RAD, StrengthPolar, closed_outline

SERIES = (("peak", BLUE, "-", "o"), ("mean", VERMILLION, "-", "s"),
          ("line shown (the robot's limit)", GREY, "--", ""))
"""Each drawn series (StrengthPolar.drawn's order): its legend, colour, line and marker."""


def draw_strength_polar(figure, rect: tuple[float, float, float, float],
                        polar: StrengthPolar):
    """A polar axes at `rect` (figure fraction) of `figure` with the plot drawn; returns
    the axes. A direction not measured is a gap in the polygons and says so in its
    label (closed_outline says why)."""
    axes = figure.add_axes(rect, projection="polar")
    axes.set_theta_offset(SEEN_FROM_SEAT_RAD)
    axes.set_theta_direction(1)  # counter-clockwise, as the robot's frame measures them
    for values, (label, colour, style, marker) in zip(polar.drawn(), SERIES, strict=False):
        theta, radius = closed_outline(polar.angles_rad, values)
        axes.plot(theta, radius, color=colour, linestyle=style, marker=marker,
                  markersize=4, linewidth=1.6 if style == "-" else 1.0, label=label)
    missing = set(polar.not_measured)
    axes.set_xticks(polar.angles_rad)
    axes.set_xticklabels([label + ("\nnot measured" if d in missing else "")
                          for d, label in zip(polar.directions_deg, polar.labels(),
                                              strict=True)], fontsize=8)
    axes.tick_params(axis="x", pad=2)
    largest = polar.largest_n()
    axes.set_ylim(0.0, _radial_top(largest))
    axes.yaxis.set_major_formatter(lambda value, _pos: f"{value:g} N")
    axes.tick_params(axis="y", labelsize=7, labelcolor=GREY)
    axes.set_rlabel_position(math.degrees(math.pi / 8))  # between two directions' spokes
    axes.set_title("Force along each direction (N), as seen from the patient's seat",
                   fontsize=9, pad=18)
    axes.legend(loc="upper left", bbox_to_anchor=(1.02, 1.02), fontsize=8, frameon=False)
    return axes


def _radial_top(largest_n: float) -> float:
    """The radial axis' end, N: a little beyond the largest force so a polygon at its
    largest does not sit on the outer circle (1 N when nothing is drawn)."""
    return 1.1 * largest_n if largest_n > 0 else 1.0
