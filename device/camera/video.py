"""A trial's recorded video read back frame by frame for pose estimation, with its
timestamps sidecar (device.camera.capture), and every way it can be unusable said in one
line: missing, empty, corrupt, frames of changing size, or frames that do not match their
timestamps.

A video file is read as fast as it decodes (no pacing). OpenCV is imported only when a
video is opened, its libraries' own lines kept off the terminal (device.camera.opencv).
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from device.camera.capture import timestamps_path
from device.camera.opencv import import_cv2, open_capture
from device.errors import VideoError

# A recording stopped by a crash may have written one frame's stamp and not its picture
# (or the reverse): that much disagreement is tolerated, more is not the same recording.
FRAME_COUNT_SLACK = 1


@dataclass(frozen=True, slots=True)
class VideoInfo:
    """What a video file holds, as read from its header and its sidecar."""

    path: Path
    frames: int  # frames in the file (the container's count; decoding may find fewer)
    width: int
    height: int
    fps: float
    stamps_s: np.ndarray  # time.monotonic() of each frame, from the sidecar


def _cv2():
    try:
        cv2 = import_cv2()
    except ImportError as exc:  # pragma: no cover - the setup installs it
        raise VideoError(f"reading video needs OpenCV, which is not installed here ({exc}); "
                         "run scripts/setup-venv") from exc
    return cv2


def open_video(path: str | os.PathLike) -> VideoInfo:
    """Check a video and its timestamps sidecar and say what they hold; VideoError with one
    line when either cannot be used."""
    path = Path(path)
    if not path.is_file():
        raise VideoError(f"video {path} does not exist; record the trial with the camera on "
                         "(Parameters tab, With camera), or give the video's path")
    if path.stat().st_size == 0:
        raise VideoError(f"video {path} is empty (0 bytes): the camera recorded nothing")
    sidecar = timestamps_path(path)
    if not sidecar.is_file():
        raise VideoError(f"video {path} has no timestamps file {sidecar.name} beside it; "
                         "without it its frames cannot be placed on the trial's clock")
    stamps = _timestamps(sidecar)
    cv2 = _cv2()
    capture = open_capture(cv2, path)
    try:
        if not capture.isOpened():
            raise VideoError(f"video {path} cannot be decoded: the file is damaged or not a "
                             "video (.mp4 or .avi)")
        frames = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        width = int(capture.get(cv2.CAP_PROP_FRAME_WIDTH))
        height = int(capture.get(cv2.CAP_PROP_FRAME_HEIGHT))
        fps = float(capture.get(cv2.CAP_PROP_FPS))
        ok, image = capture.read()
        if not ok or image is None:
            raise VideoError(f"video {path} holds no readable frame: the file is damaged or "
                             "the recording was cut before its first frame")
    finally:
        capture.release()
    if abs(frames - stamps.size) > FRAME_COUNT_SLACK:
        raise VideoError(
            f"video {path} has {frames} frames but its timestamps list {stamps.size}; they "
            "are not the same recording, or one was cut short")
    return VideoInfo(path, frames, width, height, fps, stamps)


def _timestamps(sidecar: Path) -> np.ndarray:
    """The sidecar's stamps, checked: `frame,monotonic_s` rows, the frames 0, 1, 2… in
    order, the stamps finite and increasing; VideoError in one line otherwise."""
    try:
        rows = np.loadtxt(sidecar, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError, UnicodeDecodeError) as exc:
        # numpy's advice to its programmer ("use `usecols`…") is no help to the reader
        said = _one_line(exc).split("; use `usecols`")[0].rstrip(". ")
        raise VideoError(f"timestamps {sidecar} cannot be read ({said}); it must be the CSV "
                         "the console writes (frame,monotonic_s)") from exc
    if rows.size == 0:
        raise VideoError(f"timestamps {sidecar} list no frames: the camera recorded nothing")
    if rows.shape[1] != 2:
        raise VideoError(f"timestamps {sidecar} have {rows.shape[1]} columns, not the two "
                         "the console writes (frame,monotonic_s); the file is damaged")
    if not np.array_equal(rows[:, 0], np.arange(rows.shape[0])):
        raise VideoError(f"timestamps {sidecar} do not number the frames 0, 1, 2… in order; "
                         "the file is damaged")
    stamps = rows[:, 1]
    if not np.isfinite(stamps).all() or np.any(np.diff(stamps) <= 0):
        raise VideoError(f"timestamps {sidecar} are not increasing times; the file is "
                         "damaged")
    return stamps


def _one_line(exc: BaseException) -> str:
    """FFmpeg's and OpenCV's messages carry line breaks; every refusal is one line."""
    return " ".join(str(exc).split())


def frames(info: VideoInfo) -> Iterator[tuple[int, np.ndarray]]:
    """(index, BGR picture) for every frame that decodes, in order. A picture of another
    size than the first, or a decoding error part-way, raises VideoError naming the
    frame."""
    cv2 = _cv2()
    capture = open_capture(cv2, info.path)
    try:
        index = 0
        while True:
            try:
                ok, image = capture.read()
            except cv2.error as exc:
                raise VideoError(f"video {info.path}: frame {index} cannot be decoded "
                                 f"({_one_line(exc)});"
                                 " the file is damaged") from exc
            if not ok or image is None:
                return
            if image.shape[:2] != (info.height, info.width):
                raise VideoError(
                    f"video {info.path}: frame {index} is {image.shape[1]}×{image.shape[0]} "
                    f"px, the video {info.width}×{info.height}; the file is damaged")
            yield index, image
            index += 1
    finally:
        capture.release()


class VideoReader:
    """Random access to a video's frames, for replay: `read(index)` is the picture at that
    frame (BGR), or None past the end. Keeps the file open; reading on in order is cheap,
    a jump seeks."""

    def __init__(self, info: VideoInfo) -> None:
        self.info = info
        self._cv2 = _cv2()
        self._capture = open_capture(self._cv2, info.path)
        if not self._capture.isOpened():
            raise VideoError(f"video {info.path} cannot be decoded: the file is damaged")
        self._next = 0

    def read(self, index: int) -> np.ndarray | None:
        if self._capture is None or not 0 <= index < self.info.frames:
            return None
        if index != self._next:
            self._capture.set(self._cv2.CAP_PROP_POS_FRAMES, index)
        ok, image = self._capture.read()
        self._next = index + 1 if ok else -1
        return image if ok else None

    def close(self) -> None:
        capture, self._capture = self._capture, None
        if capture is not None:
            capture.release()
