"""How the window writes a figure: a fixed number of decimals, a true minus sign, and a
dash where the figure is undefined (before the exercise starts, a missing channel)."""

from __future__ import annotations

import math


def format_number(value: float | None, decimals: int = 1) -> str:
    if value is None or not math.isfinite(value):
        return "–"
    return f"{value:.{decimals}f}".replace("-", "−")
