"""Tables of virtual healthy controls for the fitting and CLI tests: known transforms and
coefficients, written as the CSV `rehab norms fit` and `rehab norms mdc` read."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np

HEADER = ["subject", "age_years", "sex", "handedness", "tested_side", "robot",
          "vgr_reaction_time_s", "vgr_max_speed_m_s", "range_area_m2", "range_area_ratio"]


def people(n: int, rng) -> list[dict]:
    return [{"subject": f"C{i:03d}", "age_years": round(float(rng.uniform(20, 80)), 1),
             "sex": str(rng.choice(["female", "male"])),
             "handedness": "left" if rng.random() < 0.25 else "right",
             "tested_side": str(rng.choice(["right", "left"])),
             "robot": "simulator-realistic"} for i in range(n)]


def figures(person: dict, trait: np.ndarray, rng, noise: float = 1.0) -> dict:
    """A person's figures: a lasting trait (their own level) plus session noise."""
    age = person["age_years"]
    rt = float(np.exp(-1.2 + 0.008 * age + 0.12 * trait[0] + noise * rng.normal(0, 0.05)))
    speed = 0.6 - 0.003 * age + 0.06 * (person["sex"] == "male") + 0.05 * trait[1] + (
        noise * rng.normal(0, 0.02))
    area = float(np.exp(-2.5 - 0.004 * age + 0.15 * trait[2] + noise * rng.normal(0, 0.06)))
    ratio = float(1 / (1 + np.exp(-(1.5 - 0.01 * age + 0.3 * trait[3]
                                    + noise * rng.normal(0, 0.1)))))
    return {"vgr_reaction_time_s": rt, "vgr_max_speed_m_s": speed, "range_area_m2": area,
            "range_area_ratio": ratio}


def write_controls(path: Path, n: int = 200, seed: int = 0) -> Path:
    rng = np.random.default_rng(seed)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, HEADER)
        writer.writeheader()
        for person in people(n, rng):
            writer.writerow({**person, **figures(person, rng.standard_normal(4), rng)})
    return path


def write_retest(path: Path, n: int = 40, seed: int = 1) -> Path:
    """Each person twice: the same trait, new session noise."""
    rng = np.random.default_rng(seed)
    with path.open("w", newline="") as f:
        writer = csv.DictWriter(f, ["session", *HEADER])
        writer.writeheader()
        for person in people(n, rng):
            trait = rng.standard_normal(4)
            for session in (1, 2):
                writer.writerow({**person, "session": session,
                                 **figures(person, trait, rng)})
    return path
