"""Pose on the live camera, beyond the thesis (which could only run it afterwards,
Appendix A.5.1): the detector on the newest frame of a running CameraSource, on a worker
thread of its own, its keypoints published for the window to draw.

It never touches the loop: the 2 ms loop runs in its own process and reads no camera. It
takes the newest frame whenever it is free, so a slow detector skips frames instead of
falling behind; `rate_fps` says how many it keeps up with. The worker gives way to the
loop (device.background): a lower priority and the CPUs the loop does not take, for
itself and the model's own threads, which it starts.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from core.pose.keypoints import ArmKeypoints
from device.background import give_way_to_the_loop
from device.camera.capture import CameraSource
from device.camera.detector import PoseDetector

POLL_S = 0.005  # how often the worker looks for a newer frame when it has none
RATE_WINDOW = 30  # frames over which the rate is measured
STOP_TIMEOUT_S = 5.0


@dataclass(frozen=True, slots=True)
class LiveKeypoints:
    """The keypoints of frame `frame_index` (CameraSource's count), read at `time_s`
    (time.monotonic())."""

    frame_index: int
    time_s: float
    keypoints: ArmKeypoints


class LivePose:
    """start() makes the detector (on the worker) and runs it; latest() is the newest
    result; stop() ends it. A detector that cannot be made or fails sets `error` and
    stops the worker. With `give_way` (the default) the worker gives way to the loop;
    `give_way_problems` says what the OS refused of it. False keeps the window's priority
    (bench/pose_live.py measures both)."""

    def __init__(self, camera: CameraSource, make_detector: Callable[[], PoseDetector],
                 give_way: bool = True):
        self.camera = camera
        self.make_detector = make_detector
        self.give_way = give_way
        self.give_way_problems: list[str] = []
        self.error: str | None = None
        self._latest: LiveKeypoints | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._done: deque[float] = deque(maxlen=RATE_WINDOW)

    def start(self) -> LivePose:
        if self._thread is None:
            self._stop.clear()
            self._thread = threading.Thread(target=self._run, name="live pose", daemon=True)
            self._thread.start()
        return self

    def stop(self) -> None:
        self._stop.set()
        thread, self._thread = self._thread, None
        if thread is not None and thread is not threading.current_thread():
            thread.join(STOP_TIMEOUT_S)

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def latest(self) -> LiveKeypoints | None:
        with self._lock:
            return self._latest

    @property
    def rate_fps(self) -> float:
        """Frames analysed per second over the last RATE_WINDOW (0 before two)."""
        with self._lock:
            done = list(self._done)
        if len(done) < 2 or done[-1] <= done[0]:
            return 0.0
        return (len(done) - 1) / (done[-1] - done[0])

    def _run(self) -> None:
        if self.give_way:
            # before the detector is made: its thread pool inherits priority and CPUs
            self.give_way_problems = give_way_to_the_loop()
        try:
            detector = self.make_detector()
        except Exception as exc:  # the model's own errors name themselves
            self.error = f"live pose cannot start: {exc}"
            return
        last = -1
        try:
            while not self._stop.is_set():
                frame = self.camera.latest()
                if frame is None or frame.index == last:
                    if not self.camera.running and frame is not None and frame.index == last:
                        break  # the source ended and its last frame is done
                    self._stop.wait(POLL_S)
                    continue
                keypoints = detector.detect(frame.image)
                last = frame.index
                with self._lock:
                    self._latest = LiveKeypoints(frame.index, frame.time_s, keypoints)
                    self._done.append(time.monotonic())
        except Exception as exc:
            self.error = f"live pose stopped: {exc}"
        finally:
            detector.close()
