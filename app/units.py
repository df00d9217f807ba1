"""The display unit of each quantity a person reads, once for the whole console: the
window's forms and plots, the reports, the PDFs and the command line's tables.

Inside, everything is SI (metres, radians, a level from 0 to 1). At the screen:

=====================================  =======  ==========================================
quantity                               unit     where
=====================================  =======  ==========================================
positions and sizes of the set-up      cm       the form, the path plots (window, PDF), the
(centre, shoulder, radius, arm)                 report's Settings line, stored measurements
position errors (RMSE, per axis)       mm       the big numbers, the error plot, tables
speeds                                 mm/s     tables, the window's path summary
an assessment's figures                mm, mm/s the Assessments tab, its PDF page, the
(catalogued in SI: core.assessment)    °, cm²   session report (`shown`)
angles (joints, tolerance)             °        everywhere
assistance level                       %        the form, the report, the progress table
=====================================  =======  ==========================================
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from core.trial_check import MessageUnits

CM_PER_M = 100.0
"""Positions and sizes of the set-up are shown in cm."""
MM_PER_M = 1000.0
"""Position errors are shown in mm."""
MM_S_PER_M_S = 1000.0
"""Speeds are shown in mm/s."""

MEASUREMENT_UNITS = {"body_mass_kg": ("kg", 1.0), "upper_arm_m": ("cm", CM_PER_M),
                     "forearm_m": ("cm", CM_PER_M), "shoulder_m": ("cm", CM_PER_M)}
"""A patient's stored measurement (the registry's field, SI) → the unit the Registration tab
shows and takes it in, and the factor from SI (its form, its Correct row)."""

SCREEN = MessageUnits(length="cm", per_m=CM_PER_M, decimals=1,
                      speed="mm/s", per_m_s=MM_S_PER_M_S, speed_decimals=0)
"""The units of the trial check's refusals in the window (core.trial_check.check_trial)."""


def cm(length_m: float, decimals: int = 1) -> str:
    """'30.0 cm'."""
    return f"{length_m * CM_PER_M:.{decimals}f} cm"


def point_cm(point_m: Sequence[float], decimals: int = 1) -> str:
    """'(-12.0, 73.0) cm'."""
    x, y = (v * CM_PER_M for v in point_m)
    return f"({x:.{decimals}f}, {y:.{decimals}f}) cm"


def assistance_percent(level: float) -> str:
    """'40 %': the assistance level (0–1 inside) as the form shows it."""
    return f"{level * 100:.0f} %"


SHOWN = {"m": ("mm", MM_PER_M), "m/s": ("mm/s", MM_S_PER_M_S),
         "rad": ("°", 180.0 / math.pi), "m²": ("cm²", CM_PER_M ** 2)}
"""A catalogued figure's SI unit → the unit a person reads it in and the factor to it (a
unit not here, N, s, a ratio or a count, is read as it is)."""


def shown(value_si: float, unit_si: str) -> tuple[float, str]:
    """A figure's SI value and unit as a person reads them: (2.31, '°') for 0.0403 rad."""
    unit, factor = SHOWN.get(unit_si, (unit_si, 1.0))
    return value_si * factor, unit


def with_unit(text: str, unit: str) -> str:
    """'2.31°', '0.81 mm/s', '0.93' (a ratio: unit '1' or '')."""
    if unit in ("", "1"):
        return text
    return f"{text}{unit}" if unit == "°" else f"{text} {unit}"
