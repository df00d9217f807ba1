"""The pose detector: a picture in, the arm's keypoints in pixels with their visibility
out (core.pose.keypoints.ArmKeypoints). One interface, `PoseDetector`; one real model,
`MediaPipePose` (MediaPipe Pose 0.10.14, the `mp.solutions.pose` API).

Why exactly 0.10.14: it is the last release with `mp.solutions` and its pose model in
the wheel (`pose_landmark_full.tflite`, model_complexity=1), so it runs with no download,
and the last without a numpy<2 pin. Complexity 0 (lite) and 2 (heavy) are not in the
wheel: MediaPipe would fetch them from the internet at run time, which a clinic's
console must not do; they are refused by name. Newer releases dropped `mp.solutions`.

Installation (scripts/setup-venv): every mediapipe release requires
opencv-contrib-python, whose `cv2` replaces the headless build the rest of the console
uses, so mediapipe is installed with --no-deps and its real run-time needs are the
project's own dependencies. `check_installation` verifies that at run time.

Start-up noise: the first `process()` prints TensorFlow Lite's and absl's lines on the C
stderr (fd 2, which no logging setting reaches) and protobuf warns that GetPrototype is
deprecated. The model is warmed up once with fd 2 pointed at /dev/null, and that one
warning is ignored by message; nothing else is hidden.

mediapipe is imported only when a detector is made, so `device` imports without it.
"""

from __future__ import annotations

import contextlib
import importlib.metadata
import os
import sys
import warnings
from typing import Protocol

import numpy as np

from core.pose.keypoints import ArmKeypoints
from device.errors import PoseModelError

MEDIAPIPE_VERSION = "0.10.14"
# The one complexity the wheel carries; the others need a download.
BUNDLED_COMPLEXITY = 1
COMPLEXITY_NAMES = {0: "lite", 1: "full", 2: "heavy"}
# OpenCV distributions that install a `cv2` of their own over the headless one.
RIVAL_OPENCV = ("opencv-python", "opencv-contrib-python", "opencv-contrib-python-headless")
HEADLESS_OPENCV = "opencv-python-headless"
# MediaPipe Pose's landmark numbers (BlazePose topology), by the person's side.
LANDMARKS = {"right": (12, 14, 16, 11), "left": (11, 13, 15, 12)}
_PROTOBUF_WARNING = r"SymbolDatabase\.GetPrototype\(\) is deprecated"


class PoseDetector(Protocol):
    """What the pose pipeline needs of a model: keypoints of the arm in one picture."""

    side: str

    def detect(self, image_bgr: np.ndarray) -> ArmKeypoints:
        """The arm's keypoints in an H×W×3 uint8 BGR picture (OpenCV's order)."""
        ...

    def close(self) -> None: ...


def check_installation() -> None:
    """Raise PoseModelError unless mediapipe is 0.10.14 and `cv2` is the headless build."""
    try:
        version = importlib.metadata.version("mediapipe")
    except importlib.metadata.PackageNotFoundError:
        raise PoseModelError(
            "pose estimation needs MediaPipe 0.10.14, which is not installed; run "
            "scripts/setup-venv (never a plain `pip install mediapipe`)") from None
    if version != MEDIAPIPE_VERSION:
        raise PoseModelError(
            f"pose estimation needs MediaPipe {MEDIAPIPE_VERSION}, but {version} is "
            "installed (newer releases dropped the pose solution and its bundled model); "
            f"run `pip uninstall mediapipe`, then scripts/setup-venv")
    for name in RIVAL_OPENCV:
        with contextlib.suppress(importlib.metadata.PackageNotFoundError):
            importlib.metadata.version(name)
            raise PoseModelError(
                f"{name} is installed beside {HEADLESS_OPENCV}; both provide the cv2 module "
                f"and the mix breaks it. Run `pip uninstall -y {name} {HEADLESS_OPENCV}`, "
                "then scripts/setup-venv")
    try:
        importlib.metadata.version(HEADLESS_OPENCV)
    except importlib.metadata.PackageNotFoundError:
        raise PoseModelError(f"{HEADLESS_OPENCV} is not installed; run scripts/setup-venv"
                             ) from None


def check_complexity(model_complexity: int) -> int:
    """The model complexity, refusing the ones the wheel does not carry, by name."""
    if isinstance(model_complexity, bool) or model_complexity not in COMPLEXITY_NAMES:
        raise PoseModelError(f"model_complexity={model_complexity!r} does not exist; "
                             f"use {BUNDLED_COMPLEXITY} (MediaPipe's full pose model)")
    if model_complexity != BUNDLED_COMPLEXITY:
        name = COMPLEXITY_NAMES[model_complexity]
        raise PoseModelError(
            f"model_complexity={model_complexity} ({name} model) is not bundled with "
            f"MediaPipe {MEDIAPIPE_VERSION}: MediaPipe would download it from the internet "
            f"at run time, which the console does not do. Use model_complexity="
            f"{BUNDLED_COMPLEXITY} (the full model, bundled)")
    return model_complexity


class MediaPipePose:
    """MediaPipe Pose on pictures of one subject.

    `side`: the arm in use ("right" or "left", the person's own side). `video`: True for
    consecutive frames (MediaPipe tracks the person from frame to frame, running its
    person detector only when it loses them: about 55 fps at 640×480 on one core); False
    for unrelated pictures (the detector on every picture: about 34 fps)."""

    def __init__(self, side: str = "right", *, video: bool = True,
                 model_complexity: int = BUNDLED_COMPLEXITY) -> None:
        if side not in LANDMARKS:
            raise PoseModelError(f"side {side!r}: give 'right' or 'left'")
        check_complexity(model_complexity)
        check_installation()
        self.side = side
        self._indices = LANDMARKS[side]
        _ignore_protobuf_warning()
        with _quiet_stderr():
            from mediapipe.python.solutions import pose as mp_pose

            self._pose = mp_pose.Pose(static_image_mode=not video,
                                      model_complexity=model_complexity,
                                      enable_segmentation=False)
            # the first picture loads the detector and the landmark model: their
            # messages go to the C stderr now, not at the first real frame
            # (a blank picture: no person, so tracking starts afresh at the first frame;
            # reset() would restart the graph and print its messages again)
            self._pose.process(np.zeros((480, 640, 3), np.uint8))

    def detect(self, image_bgr: np.ndarray) -> ArmKeypoints:
        image = np.asarray(image_bgr)
        if image.dtype != np.uint8 or image.ndim != 3 or image.shape[2] != 3:
            raise PoseModelError(f"a picture must be H×W×3 uint8 (BGR); got {image.dtype} "
                                 f"of shape {image.shape}")
        _ignore_protobuf_warning()
        rgb = np.ascontiguousarray(image[:, :, ::-1])  # MediaPipe takes RGB
        result = self._pose.process(rgb)
        if result.pose_landmarks is None:
            return ArmKeypoints.missing()
        landmarks = result.pose_landmarks.landmark
        height, width = image.shape[:2]
        xy = np.array([[landmarks[i].x * width, landmarks[i].y * height]
                       for i in self._indices])
        # `presence` is always 0 in this API; visibility is the model's belief
        visibility = np.array([landmarks[i].visibility for i in self._indices])
        return ArmKeypoints(xy, visibility)

    def close(self) -> None:
        pose, self._pose = getattr(self, "_pose", None), None
        if pose is not None:
            pose.close()

    def __enter__(self) -> MediaPipePose:
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def _ignore_protobuf_warning() -> None:
    """Ignore protobuf's deprecation notice that mediapipe's own code triggers on every
    picture, and nothing else; added again when a test run's filters replaced it."""
    for f in warnings.filters:
        if f[0] == "ignore" and f[1] is not None and f[1].pattern == _PROTOBUF_WARNING:
            return
    warnings.filterwarnings("ignore", message=_PROTOBUF_WARNING, category=UserWarning)


@contextlib.contextmanager
def _quiet_stderr():
    """Point the C-level stderr (fd 2) at /dev/null for a moment. Under pythonw there may
    be no fd 2; then there is nothing to quieten."""
    try:
        sys.stderr.flush()
        saved = os.dup(2)
    except (OSError, AttributeError, ValueError):
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), 2)
        yield
    finally:
        os.dup2(saved, 2)
        os.close(saved)

