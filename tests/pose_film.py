"""A filmed trial for the pose tests: a detector that reports what a known camera saw
(app.pose.synthetic.film) frame after frame, and the video file with its timestamps that
`rehab pose` reads beside a trial."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import cv2
import numpy as np

from core.pose.keypoints import ArmKeypoints
from device.camera.capture import TIMESTAMPS_HEADER, timestamps_path

SIZE = (640, 480)


class ReplayDetector:
    """A PoseDetector whose k-th call reports the film's k-th frame: the pipeline after
    the detector runs exactly as on the real model. With `size`, each picture handed to
    it must be that size."""

    def __init__(self, filmed, side: str = "right", size: tuple[int, int] | None = None):
        self.filmed, self.side, self.size = filmed, side, size
        self.calls = 0
        self.closed = False

    def detect(self, image_bgr):
        if self.size is not None:
            assert image_bgr.shape == (self.size[1], self.size[0], 3)
        k = ArmKeypoints(self.filmed.keypoints_px[self.calls],
                         self.filmed.visibility[self.calls])
        self.calls += 1
        return k

    def close(self):
        self.closed = True


def write_video(path: Path, stamps, *, n_frames: int | None = None,
                size: tuple[int, int] = SIZE,
                grey: Callable[[int], int] = lambda k: 90) -> Path:
    """An MJPG video of `n_frames` (default one per stamp) flat pictures, frame k of grey
    level `grey(k)`, and its timestamps sidecar (`frame,monotonic_s`, one row a stamp)."""
    n = len(stamps) if n_frames is None else n_frames
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, size)
    assert writer.isOpened()
    for k in range(n):
        writer.write(np.full((size[1], size[0], 3), grey(k), np.uint8))
    writer.release()
    timestamps_path(path).write_text(TIMESTAMPS_HEADER + "".join(
        f"{k},{s:.6f}\n" for k, s in enumerate(stamps)))
    return path
