"""A past trial's video for the replay slider: the frame taken at a trial time, with the
keypoints `rehab pose` found on it. Qt-free; the Video tab shows what this returns.

Frame times come from the trial's `/pose` group when pose estimation ran on this video,
else from the timestamps sidecar and the loop's clock origin (core.pose.timebase.frame_times).
`rehab pose --video` may have run on another video than the one recorded beside the trial:
its frame numbers, times and keypoints belong to that video, so the replay shows that
video when it lies beside the trial, and otherwise the trial's own video without them
(drawn on the other video's frames they would be at the wrong places and moments). A
trial without a usable video gives None: the replay works without it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import AppError
from app.pose.offline import ORIGIN_KEY, VIDEO_SUFFIXES, default_video
from app.pose.store import read_pose
from app.trials.reader import TrialData
from core.errors import CoreError
from core.pose.timebase import frame_times
from device.camera.video import VideoReader, open_video
from device.errors import DeviceError


@dataclass(frozen=True, slots=True)
class ReplayFrame:
    """The picture at a moment of the trial: frame `index`, taken at `time_s` on the
    trial's clock; `keypoints_px` (4, 2) where pose estimation saw the arm (gaps NaN), or
    None when it has not run."""

    index: int
    time_s: float
    image: np.ndarray
    keypoints_px: np.ndarray | None


class ReplayVideo:
    """`open(trial)` the trial's video, or None; `frame_at(t)` the frame taken at or before
    trial time t (None before the first or after the video); `close()`."""

    def __init__(self, reader: VideoReader, frame_t_s: np.ndarray,
                 keypoints_px: np.ndarray | None) -> None:
        self.reader = reader
        self.frame_t_s = frame_t_s
        self.keypoints_px = keypoints_px
        self.name = reader.info.path.name

    @classmethod
    def open(cls, trial: TrialData) -> ReplayVideo | None:
        try:
            pose = read_pose(trial.path)
            video = default_video(trial.path)
            if pose is not None:
                posed = trial.path.with_name(Path(str(pose["attrs"].get("video", ""))).name)
                if posed.suffix.lower() in VIDEO_SUFFIXES and posed.is_file():
                    video = posed  # the video the keypoints were found on
                elif posed.name != video.name:
                    pose = None  # another video's, not beside the trial: not on this one
            info = open_video(video)
        except (DeviceError, AppError):
            return None
        keypoints = None
        if pose is not None and "frame_time" in pose:
            t = np.full(info.stamps_s.size, np.nan)
            index = np.asarray(pose["frame_index"], dtype=int)
            keep = index < t.size
            t[index[keep]] = pose["frame_time"][keep]
            keypoints = np.full((info.stamps_s.size, 4, 2), np.nan)
            keypoints[index[keep]] = pose["frame_keypoints_px"][keep]
            visibility = np.zeros((info.stamps_s.size, 4))
            visibility[index[keep]] = pose["frame_visibility"][keep]
            low = visibility < float(pose["attrs"].get("min_visibility", 0.5))
            keypoints[low] = np.nan
        else:
            origin = trial.summary.get(ORIGIN_KEY)
            c = trial.channels
            if origin is None or not math.isfinite(float(origin)):
                return None
            try:
                t = frame_times(info.stamps_s, float(origin), c["wall_time"], c["time"])
            except CoreError:
                return None
        try:
            return cls(VideoReader(info), t, keypoints)
        except DeviceError:
            return None

    def frame_at(self, t: float) -> ReplayFrame | None:
        known = np.isfinite(self.frame_t_s)
        candidates = np.flatnonzero(known & (self.frame_t_s <= t + 1e-9))
        if candidates.size == 0:
            return None
        index = int(candidates[-1])
        if t - self.frame_t_s[index] > 0.5:  # past the video's end, or a long gap
            return None
        image = self.reader.read(index)
        if image is None:
            return None
        keypoints = None if self.keypoints_px is None else self.keypoints_px[index]
        return ReplayFrame(index, float(self.frame_t_s[index]), image, keypoints)

    def close(self) -> None:
        self.reader.close()
