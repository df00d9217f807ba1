"""The camera source against a synthetic video file: frames with monotonic stamps on a
background thread, recording with a timestamps sidecar, clean stop, clear refusals."""

from __future__ import annotations

import time

import cv2
import numpy as np
import pytest

from device.camera.capture import (
    TIMESTAMPS_HEADER,
    CameraSource,
    read_timestamps,
    timestamps_path,
)
from device.errors import BackendUnavailable, RecordingError

FPS = 30.0
SIZE = (64, 48)


def write_video(path, frames: int = 12):
    """Frame k is a flat grey of level 20·k (mod 240), so a read frame tells its index."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), FPS, SIZE)
    assert writer.isOpened()
    for k in range(frames):
        writer.write(np.full((SIZE[1], SIZE[0], 3), (20 * k) % 240, np.uint8))
    writer.release()
    return path


def wait_for(condition, timeout_s: float = 5.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.005)


def test_reads_every_frame_in_order_with_monotonic_stamps(tmp_path):
    video = write_video(tmp_path / "clip.avi")
    seen = []
    with CameraSource(video, realtime=False) as camera:
        assert camera.fps == FPS
        assert camera.frame_size == SIZE
        wait_for(lambda: camera.ended)
        seen.append(camera.latest())
    assert not camera.running
    last = seen[0]
    assert camera.frames_read == 12
    assert last.index == 11
    assert last.image.shape == (SIZE[1], SIZE[0], 3)
    assert abs(float(last.image.mean()) - 220) < 4  # MJPG is lossy, not that lossy
    assert last.time_s <= time.monotonic()


def test_a_file_is_read_at_its_own_frame_rate(tmp_path):
    video = write_video(tmp_path / "clip.avi", frames=9)
    start = time.monotonic()
    with CameraSource(video) as camera:
        wait_for(lambda: camera.ended)
        elapsed = time.monotonic() - start
    # 8 frame periods after the first frame, as a 30 fps camera would deliver them.
    assert elapsed >= 8 / FPS * 0.9


def test_recording_writes_the_video_and_its_stamps(tmp_path):
    video = write_video(tmp_path / "clip.avi", frames=20)
    camera = CameraSource(video).start()
    target = tmp_path / "out" / "trial.mp4"
    sidecar = camera.start_recording(target)
    assert sidecar == timestamps_path(target) == tmp_path / "out" / "trial.timestamps.csv"
    assert camera.recording
    assert camera.recording_path == target
    wait_for(lambda: camera.recorded_frames >= 5)
    recording = camera.stop_recording()
    camera.stop()
    assert not camera.recording
    assert recording.frames >= 5
    assert recording.video_path == target

    assert sidecar.read_text().startswith(TIMESTAMPS_HEADER)
    stamps = read_timestamps(sidecar)
    assert len(stamps) == recording.frames
    assert np.all(np.diff(stamps) > 0)
    assert stamps[0] == pytest.approx(recording.first_time_s, abs=1e-6)
    # Stamped at the camera's pace: the file stands in for a 30 fps camera.
    assert np.median(np.diff(stamps)) == pytest.approx(1 / FPS, rel=0.3)

    reread = cv2.VideoCapture(str(target))
    count = 0
    while reread.read()[0]:
        count += 1
    reread.release()
    assert count == recording.frames


def test_stop_ends_the_thread_and_a_recording(tmp_path):
    video = write_video(tmp_path / "clip.avi", frames=300)
    camera = CameraSource(video).start()
    camera.start_recording(tmp_path / "trial.avi")
    wait_for(lambda: camera.recorded_frames >= 2)
    recording = camera.stop()
    assert not camera.running
    assert recording is not None
    assert recording.frames >= 2
    assert len(read_timestamps(recording.timestamps_path)) == recording.frames


def test_missing_file_and_missing_camera_are_refused_clearly(tmp_path):
    with pytest.raises(BackendUnavailable, match="does not exist"):
        CameraSource(tmp_path / "nothing.mp4").start()
    not_video = tmp_path / "notes.mp4"
    not_video.write_text("hello")
    with pytest.raises(BackendUnavailable, match=r"cannot be read as a video|no picture"):
        CameraSource(not_video).start()
    with pytest.raises(BackendUnavailable, match="camera 97 cannot be opened"):
        CameraSource(97).start()
    with pytest.raises(BackendUnavailable, match="camera number"):
        CameraSource(1.5)


def test_recording_needs_a_started_camera_and_a_known_format(tmp_path):
    video = write_video(tmp_path / "clip.avi")
    camera = CameraSource(video)
    with pytest.raises(RecordingError, match="not started"):
        camera.start_recording(tmp_path / "x.mp4")
    camera.start()
    try:
        with pytest.raises(RecordingError, match=r"\.mp4 or \.avi"):
            camera.start_recording(tmp_path / "x.mkv")
    finally:
        camera.stop()


def test_a_damaged_timestamps_line_is_refused_in_the_readers_words(tmp_path):
    """A timestamps file with a line of one column was refused with numpy's advice to its
    programmer ('use `usecols` to select a subset and avoid this error'): the refusal is
    one line naming the file and what is wrong, nothing a reader cannot act on."""
    from device.camera.video import open_video
    from device.errors import VideoError

    video = write_video(tmp_path / "clip.avi")
    rows = [f"{k},{k / FPS:.6f}" for k in range(12)]
    rows[6] = "7" * 2000
    timestamps_path(video).write_text(TIMESTAMPS_HEADER + "\n".join(rows) + "\n")
    with pytest.raises(VideoError) as refused:
        open_video(video)
    said = str(refused.value)
    assert "\n" not in said
    assert said.startswith(f"timestamps {timestamps_path(video)} cannot be read (")
    assert "usecols" not in said
