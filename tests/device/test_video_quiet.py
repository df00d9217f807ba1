"""A damaged video's refusal is the only line on stderr: FFmpeg's decoder, OpenCV's logger
and OpenCV's own AVI reader wrote theirs around it (device.camera.opencv)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from tests.pose_film import write_video

ROOT = Path(__file__).resolve().parents[2]

CHILD = """
import sys
from device.camera.video import frames, open_video
from device.errors import VideoError
try:
    info = open_video(sys.argv[1])
    print("frames", sum(1 for _ in frames(info)))
except VideoError as exc:
    print(f"rehab pose: error: {exc}", file=sys.stderr)
"""


def _read_in_a_new_process(video: Path) -> subprocess.CompletedProcess:
    """OpenCV's backends are set up once a process: a fresh one, without the variables
    that would let the lines through."""
    env = {k: v for k, v in os.environ.items()
           if k not in ("OPENCV_FFMPEG_LOGLEVEL", "OPENCV_LOG_LEVEL", "OPENCV_FFMPEG_DEBUG")}
    env["PYTHONPATH"] = str(ROOT)
    return subprocess.run([sys.executable, "-c", CHILD, str(video)], capture_output=True,
                          env=env, cwd=ROOT, timeout=120, check=True)


@pytest.mark.parametrize(("cut", "said"), [
    (lambda data: data[:1000], "rehab pose: error: video {} cannot be decoded"),
    (lambda data: data[:-5000], None),  # its last frames lost: FFmpeg said "overread"
])
def test_a_cut_video_leaves_only_the_console_s_line_on_stderr(tmp_path, cut, said):
    whole = write_video(tmp_path / "whole.avi", [k / 30 for k in range(60)],
                        grey=lambda k: (37 * k) % 256)
    video = tmp_path / "cut.avi"
    video.write_bytes(cut(whole.read_bytes()))
    (tmp_path / "cut.timestamps.csv").write_bytes(
        (tmp_path / "whole.timestamps.csv").read_bytes())
    done = _read_in_a_new_process(video)
    err = done.stderr.decode("utf-8", "replace")
    if said is None:
        assert err == ""
        assert done.stdout.startswith(b"frames ")
    else:
        assert err.count("\n") == 1
        assert err.startswith(said.format(video))
