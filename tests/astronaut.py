"""The astronaut photograph (scikit-image) played as a camera: a video file of it, for the
live pose's tests (tests/device/test_live_pose.py, tests/ui/test_tabs_video.py)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
from skimage import data

CLIP_S = 30.0
"""As long as the tests wait for the model (30 s): on a loaded machine MediaPipe took more
than the 10 s the clip once lasted to start, and a clip that ended first left nothing to
detect."""


def astronaut_clip(path: Path, seconds: float = CLIP_S) -> Path:
    """A 512 × 512 MJPG video of the photograph at 30 frames a second, `seconds` long."""
    image = np.ascontiguousarray(data.astronaut()[:, :, ::-1])
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (512, 512))
    for _ in range(round(30 * seconds)):
        writer.write(image)
    writer.release()
    return path
