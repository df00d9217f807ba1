"""One frame's arm keypoints as a detector reports them, and the rule that turns a
keypoint the detector is not sure of into a gap.

A pose model always returns a position for every landmark, guessed or not; its
visibility says how likely the landmark is really in view. A position below the
visibility threshold is not used: it becomes NaN, a gap, and stays one through every
later step (the table plane, the angles, the 2 ms series). Nothing here invents it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_range

# The order of the keypoints in every (..., 4, 2) array of this room.
SHOULDER, ELBOW, WRIST, OTHER_SHOULDER = range(4)
KEYPOINT_NAMES = ("shoulder", "elbow", "wrist", "other_shoulder")

# MediaPipe's own examples draw landmarks above 0.5; the astronaut photograph's wrist,
# cut by the picture's edge, reads 0.32 and its shoulders 0.998 (docs/architecture.md).
DEFAULT_MIN_VISIBILITY = 0.5


@dataclass(frozen=True, slots=True)
class ArmKeypoints:
    """The arm in use (shoulder, elbow, wrist) and the other side's shoulder in one picture.

    `xy_px` (4, 2): x to the right, y down, in pixels of the picture; `visibility` (4,):
    0–1, the detector's belief that the keypoint is in view. No person found: all NaN
    with visibility 0.
    """

    xy_px: np.ndarray
    visibility: np.ndarray

    @classmethod
    def missing(cls) -> ArmKeypoints:
        return cls(np.full((4, 2), np.nan), np.zeros(4))

    def gapped(self, min_visibility: float = DEFAULT_MIN_VISIBILITY) -> np.ndarray:
        """The positions (4, 2) with every keypoint below `min_visibility` made NaN."""
        return with_gaps(self.xy_px, self.visibility, min_visibility)


def with_gaps(xy, visibility, min_visibility: float = DEFAULT_MIN_VISIBILITY) -> np.ndarray:
    """Positions (..., K, 2) with those whose visibility (..., K) is below `min_visibility`,
    or is not finite, replaced by NaN."""
    check_range("min_visibility", min_visibility, 0.0, 1.0)
    xy = np.array(xy, dtype=float)
    visibility = np.asarray(visibility, dtype=float)
    if xy.shape[-1] != 2 or xy.shape[:-1] != visibility.shape:
        raise ParameterError("visibility", visibility.shape,
                             f"one visibility per keypoint of shape {xy.shape[:-1]}")
    low = ~(visibility >= min_visibility)  # NaN visibility is low too
    xy[low] = np.nan
    return xy
