"""OpenCV imported the one way the console uses it: its libraries' own lines kept off the
terminal, and videos read through FFmpeg.

A damaged video's refusal is one line (device.camera.video), but the libraries under
OpenCV wrote their own around it on stderr: FFmpeg's decoder (`[mjpeg @ 0x55…] overread
8`), OpenCV's logger (`[ WARN:0@0.02] global cap.cpp:212 open VIDEOIO(FFMPEG): …`) and
OpenCV's own AVI reader, tried after FFmpeg failed, which prints raw bytes of the damaged
header (`Unexpected element. Expected: LIST. Got: ^HV.`) and has no switch. So:

* `OPENCV_FFMPEG_LOGLEVEL` is set to -8 (AV_LOG_QUIET) before FFmpeg is first used:
  OpenCV reads it when its FFmpeg backend starts, which is at the first capture, not at
  `import cv2` (OpenCV's environment reference: set before use; on Windows a change of
  the environment made by Python may not reach OpenCV's C runtime, so there a line may
  still show);
* OpenCV's logger is lowered to errors (`cv2.utils.logging.setLogLevel`);
* `open_capture` asks for the FFmpeg backend when this OpenCV has it, so no other reader
  is tried on a file FFmpeg refused.

A technician who wants the lines back sets OPENCV_FFMPEG_LOGLEVEL (e.g. 32, FFmpeg's
info) or OPENCV_LOG_LEVEL (e.g. INFO) before starting the console: neither is changed
when set. The console's own messages never go through these libraries.
"""

from __future__ import annotations

import os
from types import ModuleType

FFMPEG_QUIET = "-8"
"""AV_LOG_QUIET in FFmpeg's libavutil/log.h: print nothing."""


def import_cv2() -> ModuleType:
    """cv2 with the libraries' logs quietened (ImportError when OpenCV is not installed)."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", FFMPEG_QUIET)
    import cv2

    if "OPENCV_LOG_LEVEL" not in os.environ:
        logging = getattr(getattr(cv2, "utils", None), "logging", None)
        set_level = getattr(logging, "setLogLevel", None) or getattr(cv2, "setLogLevel", None)
        level = getattr(logging, "LOG_LEVEL_ERROR", 2)  # 2 is ERROR in OpenCV 4 and 5
        if set_level is not None:
            set_level(level)
    return cv2


def open_capture(cv2: ModuleType, path: str | os.PathLike):
    """A cv2.VideoCapture of a file, through FFmpeg when this OpenCV has it."""
    ffmpeg = getattr(cv2, "CAP_FFMPEG", None)
    registry = getattr(cv2, "videoio_registry", None)
    if ffmpeg is not None and registry is not None and registry.hasBackend(ffmpeg):
        return cv2.VideoCapture(os.fspath(path), ffmpeg)
    return cv2.VideoCapture(os.fspath(path))
