"""Joint angles from two sources side by side: RMSE and bias per joint, as Table 3.4.

Table 3.4 defines each error as the other source's value minus the equation solver's
("regression"); here `error = other − reference` with the same sign, and the bias is the
mean error. Differences are wrapped into (−π, π] so two angle readings a turn apart count
as equal. Samples where either source has a gap are left out and counted.

Reference angles from elsewhere (a goniometer's frames, a motion-capture system's
series) come in as a CSV file: `read_reference_csv`.
"""

from __future__ import annotations

import csv
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from core.errors import CoreError, ParameterError
from core.pose.angles import wrap

JOINTS = ("shoulder", "elbow")


@dataclass(frozen=True, slots=True)
class JointError:
    """One joint's agreement: `rmse_rad`, `bias_rad` (mean of other − reference),
    `max_abs_rad`, over `n` samples both had."""

    joint: str
    rmse_rad: float
    bias_rad: float
    max_abs_rad: float
    n: int

    def to_dict(self, prefix: str) -> dict[str, float]:
        return {f"{prefix}{self.joint}_rmse_rad": self.rmse_rad,
                f"{prefix}{self.joint}_bias_rad": self.bias_rad,
                f"{prefix}{self.joint}_max_abs_rad": self.max_abs_rad,
                f"{prefix}{self.joint}_n": float(self.n)}


def joint_errors(reference, other) -> tuple[JointError, JointError]:
    """Shoulder and elbow errors of `other` (N, 2) against `reference` (N, 2), rad."""
    ref = np.asarray(reference, dtype=float)
    oth = np.asarray(other, dtype=float)
    if ref.shape != oth.shape or ref.ndim != 2 or ref.shape[1] != 2:
        raise ParameterError("angles", f"{ref.shape} and {oth.shape}",
                             "two (N, 2) arrays of (shoulder, elbow)")
    result = []
    for j, name in enumerate(JOINTS):
        d = wrap(oth[:, j] - ref[:, j])
        d = d[np.isfinite(d)]
        if d.size == 0:
            result.append(JointError(name, math.nan, math.nan, math.nan, 0))
            continue
        result.append(JointError(name, float(np.sqrt(np.mean(d * d))), float(np.mean(d)),
                                 float(np.max(np.abs(d))), int(d.size)))
    return result[0], result[1]


class ReferenceCSVError(CoreError, ValueError):
    """A reference-angle file cannot be used; the message names the file, the line and
    what to do."""


@dataclass(frozen=True, slots=True)
class ReferenceAngles:
    """Reference angles from a CSV: either per video frame (`frame` (K,) ints) or per time
    on the trial's clock (`time_s` (K,)), and (shoulder, elbow) in the ISB display
    convention (`isb_rad` (K, 2)), as a goniometer reads them."""

    frame: np.ndarray | None
    time_s: np.ndarray | None
    isb_rad: np.ndarray


def read_reference_csv(path: str | os.PathLike) -> ReferenceAngles:
    """A CSV with a header naming `frame` or `time_s`, then `shoulder_deg` and `elbow_deg`
    (ISB angles, degrees, as a goniometer shows them), one row per reference instant."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = list(csv.reader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ReferenceCSVError(f"reference angles {path}: cannot be read ({exc}); give a "
                                "UTF-8 CSV file") from exc
    rows = [r for r in rows if r and any(c.strip() for c in r)]
    if not rows:
        raise ReferenceCSVError(f"reference angles {path}: the file is empty; it needs a "
                                "header (frame or time_s, shoulder_deg, elbow_deg) and rows")
    header = [c.strip().lower() for c in rows[0]]
    key = "frame" if "frame" in header else "time_s" if "time_s" in header else None
    if key is None or "shoulder_deg" not in header or "elbow_deg" not in header:
        raise ReferenceCSVError(
            f"reference angles {path}: the header is {','.join(header)}; it must name "
            "frame or time_s, and shoulder_deg and elbow_deg")
    columns = [header.index(key), header.index("shoulder_deg"), header.index("elbow_deg")]
    values = []
    for line, row in enumerate(rows[1:], start=2):
        try:
            values.append([float(row[c]) for c in columns])
        except (IndexError, ValueError):
            raise ReferenceCSVError(f"reference angles {path}, line {line}: "
                                    f"{','.join(row)!r} is not three numbers") from None
    data = np.array(values, dtype=float).reshape(-1, 3)
    if data.shape[0] == 0:
        raise ReferenceCSVError(f"reference angles {path}: the header has no rows under it")
    if not np.isfinite(data).all():
        raise ReferenceCSVError(f"reference angles {path}: a value is not a finite number")
    if np.any(np.diff(data[:, 0]) <= 0):
        raise ReferenceCSVError(f"reference angles {path}: the {key} column must increase")
    isb = np.radians(data[:, 1:])
    if key == "frame":
        if np.any(data[:, 0] != np.round(data[:, 0])) or np.any(data[:, 0] < 0):
            raise ReferenceCSVError(f"reference angles {path}: frames are whole numbers "
                                    "from 0")
        return ReferenceAngles(data[:, 0].astype(np.int64), None, isb)
    return ReferenceAngles(None, data[:, 0], isb)
