"""A camera, or a video file standing in for one, read on a background thread, with
optional recording to a video file and a timestamps sidecar.

The thesis filmed its sessions at 30 frames per second beside the robot's 2 ms
data and interpolated the pose estimates to 500 Hz (Appendix A.5.1). That needs
each frame's time on the same clock as the robot's samples: every frame here is
stamped with `time.monotonic()` when it was read (CLOCK_MONOTONIC, one clock for
every process on the machine, so the loop process can stamp its start with the
same clock), and a recording writes those stamps beside the video as CSV:

    frame,monotonic_s
    0,18234.501233
    1,18234.534601

`frame` is the frame's position in the video file (0-based), so frame k of the
video was read at monotonic_s[k]. The stamp is when the driver handed the frame
over, a few ms after exposure; the offset is constant for one camera.

Qt-free: the window shows `latest()` at its own pace. OpenCV is imported only
when a source starts, so `device` stays importable without it.
"""

from __future__ import annotations

import contextlib
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from device.camera.opencv import import_cv2
from device.errors import BackendUnavailable, RecordingError
from device.safewrite import (
    OutputRefused,
    claim_private_file,
    make_private_folders,
    new_private_file,
)

DEFAULT_FPS = 30.0  # when a camera does not say (CAP_PROP_FPS reads 0)
FOURCC_BY_SUFFIX = {".mp4": "mp4v", ".avi": "MJPG"}
TIMESTAMPS_SUFFIX = ".timestamps.csv"
TIMESTAMPS_HEADER = "frame,monotonic_s\n"
# The sidecar is flushed this often, so a crash loses at most a second of stamps.
FLUSH_EVERY_FRAMES = 30
STOP_TIMEOUT_S = 2.0


@dataclass(frozen=True, slots=True)
class Frame:
    """One picture: `index` counts frames read since start (0-based), `time_s` is
    time.monotonic() when it was read, `image` is H×W×3 uint8 in OpenCV's BGR order."""

    index: int
    time_s: float
    image: np.ndarray


@dataclass(frozen=True, slots=True)
class Recording:
    """A finished recording: the video, its timestamps sidecar and what they hold."""

    video_path: Path
    timestamps_path: Path
    frames: int
    first_time_s: float
    last_time_s: float


def timestamps_path(video_path: str | os.PathLike) -> Path:
    """The sidecar of a video: trial.mp4 -> trial.timestamps.csv."""
    video_path = Path(video_path)
    return video_path.with_name(video_path.stem + TIMESTAMPS_SUFFIX)


def read_timestamps(path: str | os.PathLike) -> np.ndarray:
    """The monotonic time of each frame of a recording, from its sidecar (s)."""
    path = Path(path)
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.size == 0:
        return np.zeros(0)
    return data[:, 1]


def _cv2():
    try:
        cv2 = import_cv2()
    except ImportError as exc:
        raise BackendUnavailable(
            f"the camera needs OpenCV, which is not installed here ({exc}); install "
            "opencv-python-headless or use the console without a camera"
        ) from exc
    return cv2


class _Recorder:
    """A video writer and its timestamps sidecar; used from the capture thread."""

    def __init__(self, cv2, path: Path, fps: float, size: tuple[int, int]) -> None:
        suffix = path.suffix.lower()
        if suffix not in FOURCC_BY_SUFFIX:
            raise RecordingError(
                f"cannot record video to {path}: give a file ending in "
                f"{' or '.join(FOURCC_BY_SUFFIX)}"
            )
        stamps = timestamps_path(path)
        try:
            # new files, 0600, never over one that is there (device.safewrite): the video
            # is claimed empty and OpenCV truncates it, which keeps the mode
            make_private_folders(path.parent)
            self.stamps = new_private_file(stamps, encoding="ascii")
        except OutputRefused as exc:
            raise RecordingError(f"cannot write video beside {path}: {exc}") from exc
        try:
            claim_private_file(path)
        except OutputRefused as exc:
            self._abandon(stamps)
            raise RecordingError(f"cannot write video beside {path}: {exc}") from exc
        self.writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*FOURCC_BY_SUFFIX[suffix]),
                                      fps, size)
        if not self.writer.isOpened():
            self._abandon(stamps, path)
            raise RecordingError(
                f"cannot record video to {path}: OpenCV could not open a "
                f"{FOURCC_BY_SUFFIX[suffix]} writer. Try the other format "
                f"({' or '.join(FOURCC_BY_SUFFIX)}) or another folder"
            )
        self.stamps.write(TIMESTAMPS_HEADER)
        self.path = path
        self.frames = 0
        self.first = float("nan")
        self.last = float("nan")

    def _abandon(self, *made: Path) -> None:
        """Close the timestamps and remove the files made for a video that cannot start."""
        self.stamps.close()
        for path in made:
            with contextlib.suppress(OSError):
                path.unlink()

    def write(self, time_s: float, image: np.ndarray) -> None:
        self.writer.write(image)
        self.stamps.write(f"{self.frames},{time_s:.6f}\n")
        if self.frames == 0:
            self.first = time_s
        self.last = time_s
        self.frames += 1
        if self.frames % FLUSH_EVERY_FRAMES == 0:
            self.stamps.flush()

    def close(self) -> Recording:
        self.writer.release()
        self.stamps.close()
        return Recording(self.path, timestamps_path(self.path), self.frames, self.first,
                         self.last)


class CameraSource:
    """Frames from a camera (an int: the system's camera number) or a video file (a
    path; read at its own frame rate when `realtime`, as a camera would deliver it).

    start() opens the source and starts the capture thread; latest() is the newest
    frame; start_recording()/stop_recording() write what is read from then on;
    stop() ends everything. A source that ends (file) or fails (camera unplugged)
    stops by itself: `ended` or `error` says which.
    """

    def __init__(self, source: int | str | os.PathLike, *, realtime: bool = True) -> None:
        if isinstance(source, bool) or not isinstance(source, int | str | os.PathLike):
            raise BackendUnavailable(
                f"camera source {source!r}: give a camera number (0 for the first) or a "
                "video file path"
            )
        self.source = source if isinstance(source, int) else Path(source)
        self.realtime = realtime
        self.fps = DEFAULT_FPS
        self.frame_size: tuple[int, int] = (0, 0)  # width, height
        self.error: str | None = None
        self.ended = False
        self._capture = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._latest: Frame | None = None
        self._count = 0
        self._recorder: _Recorder | None = None
        self._record_lock = threading.Lock()
        self._cv2 = None

    @property
    def description(self) -> str:
        if isinstance(self.source, int):
            return f"camera {self.source}"
        return f"video file {self.source.name}"

    # -- life cycle -----------------------------------------------------------------
    def start(self) -> CameraSource:
        if self._thread is not None:
            return self
        cv2 = self._cv2 = _cv2()
        if isinstance(self.source, Path) and not self.source.is_file():
            raise BackendUnavailable(
                f"video file {self.source} does not exist; check the path, or give a camera "
                "number (0 for the first camera)"
            )
        target = self.source if isinstance(self.source, int) else str(self.source)
        capture = cv2.VideoCapture(target)
        if not capture.isOpened():
            capture.release()
            raise BackendUnavailable(self._cannot_open())
        ok, image = capture.read()
        if not ok or image is None:
            capture.release()
            raise BackendUnavailable(
                f"{self.description} opened but gave no picture; "
                + ("check the lens cover and the cable, or try another camera number"
                   if isinstance(self.source, int) else "the file holds no readable frames")
            )
        fps = capture.get(cv2.CAP_PROP_FPS)
        self.fps = float(fps) if fps and np.isfinite(fps) and fps > 0 else DEFAULT_FPS
        self.frame_size = (int(image.shape[1]), int(image.shape[0]))
        self._capture = capture
        self._stop.clear()
        self._publish(time.monotonic(), image)
        self._thread = threading.Thread(target=self._run, name=f"camera {self.source}",
                                        daemon=True)
        self._thread.start()
        return self

    def _cannot_open(self) -> str:
        if isinstance(self.source, int):
            return (
                f"camera {self.source} cannot be opened: it is not connected, or another "
                "program is using it. Plug it in, close the other program, or try another "
                "camera number"
            )
        return (f"video file {self.source} cannot be read as a video; choose another file "
                "(.mp4 or .avi)")

    def stop(self) -> Recording | None:
        """Stop reading (and recording); returns the recording if one was running."""
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(STOP_TIMEOUT_S)
        recording = self.stop_recording() if self.recording else None
        if self._capture is not None and (thread is None or not thread.is_alive()):
            self._capture.release()
            self._capture = None
        return recording

    def __enter__(self) -> CameraSource:
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    # -- frames -----------------------------------------------------------------------
    def latest(self) -> Frame | None:
        with self._lock:
            return self._latest

    @property
    def frames_read(self) -> int:
        with self._lock:
            return self._count

    def _publish(self, time_s: float, image: np.ndarray) -> None:
        with self._lock:
            frame = Frame(self._count, time_s, image)
            self._latest = frame
            self._count += 1
        with self._record_lock:
            if self._recorder is not None:
                try:
                    self._recorder.write(time_s, image)
                except (OSError, ValueError) as exc:  # disk full, closed file
                    self.error = f"recording stopped: {exc}"
                    self._recorder.close()
                    self._recorder = None

    def _run(self) -> None:
        capture = self._capture
        period = 1.0 / self.fps
        due = time.monotonic() + period
        try:
            while not self._stop.is_set():
                if self.realtime and isinstance(self.source, Path):
                    wait = due - time.monotonic()
                    if wait > 0 and self._stop.wait(wait):
                        break
                    due += period
                ok, image = capture.read()
                if not ok or image is None:
                    if isinstance(self.source, int):
                        self.error = (f"camera {self.source} stopped delivering pictures; "
                                      "check its cable, then choose it again")
                    else:
                        self.ended = True
                    break
                self._publish(time.monotonic(), image)
        except Exception as exc:  # an OpenCV error must not vanish with the thread
            self.error = f"{self.description} failed: {exc}"

    # -- recording --------------------------------------------------------------------
    @property
    def recording(self) -> bool:
        with self._record_lock:
            return self._recorder is not None

    @property
    def recording_path(self) -> Path | None:
        with self._record_lock:
            return self._recorder.path if self._recorder is not None else None

    @property
    def recorded_frames(self) -> int:
        with self._record_lock:
            return self._recorder.frames if self._recorder is not None else 0

    def start_recording(self, path: str | os.PathLike) -> Path:
        """Write every frame read from now on to `path` (.mp4 or .avi) and its stamps to
        the sidecar (timestamps_path). Returns the sidecar's path."""
        if self._cv2 is None or self.frame_size == (0, 0):
            raise RecordingError(f"{self.description} is not started; start it before recording")
        recorder = _Recorder(self._cv2, Path(path), self.fps, self.frame_size)
        with self._record_lock:
            previous, self._recorder = self._recorder, recorder
        if previous is not None:
            previous.close()
        return timestamps_path(path)

    def stop_recording(self) -> Recording | None:
        with self._record_lock:
            recorder, self._recorder = self._recorder, None
        return recorder.close() if recorder is not None else None
