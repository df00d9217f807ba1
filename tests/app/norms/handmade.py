"""A hand-made norms document whose Z-scores and task score the tests compute by hand."""

from __future__ import annotations

import copy


def handmade() -> dict:
    return copy.deepcopy(HANDMADE)


HANDMADE = {
    "format": "rehab-console-norms",
    "format_version": 1,
    "source": "hand-made for the tests, 3 Dec 2026",
    "simulated": False,
    "covariates": {
        "age_years": [20, 80],
        "sex": ["female", "male"],
        "handedness": ["right", "left"],
        "tested_side": ["right", "left"],
        "robot": ["simulator-realistic"],
    },
    "figures": {
        "vgr_reaction_time_s": {
            "transform": {"kind": "box-cox", "lambda": 0.5, "shift": 0.0},
            "coefficients": {"intercept": -1.0, "age_years": 0.01, "sex=male": 0.05,
                             "handedness=left": 0.0, "tested_side=left": 0.02},
            "residual_sd": 0.1, "n": 100, "worse": "higher", "mdc95": 0.08,
        },
        "vgr_max_speed_m_s": {
            "transform": {"kind": "none"},
            "coefficients": {"intercept": 0.5, "age_years": -0.002, "sex=male": 0.0,
                             "handedness=left": 0.0, "tested_side=left": 0.0},
            "residual_sd": 0.05, "n": 100, "worse": "lower",
        },
    },
    "tasks": {
        "reaching": {
            "figures": ["vgr_reaction_time_s", "vgr_max_speed_m_s"],
            "transform": {"kind": "box-cox", "lambda": 0.5, "shift": 0.0},
            "mean": 1.0, "sd": 0.4, "n": 100, "mdc95": 0.9,
        },
    },
}
