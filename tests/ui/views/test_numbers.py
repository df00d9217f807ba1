"""How the window writes a figure."""

from __future__ import annotations

import math

from ui.views.numbers import format_number


def test_decimals_a_true_minus_and_a_dash_for_undefined():
    assert format_number(12.345) == "12.3"
    assert format_number(-0.5, 2) == "−0.50"
    assert format_number(3.0, 0) == "3"
    for undefined in (None, math.nan, math.inf):
        assert format_number(undefined) == "–"
