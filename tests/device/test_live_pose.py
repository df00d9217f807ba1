"""Live pose on a running camera source: the real model on the astronaut photograph
played as a camera, keypoints published per frame, the rate, a clean stop, and a detector
that cannot start said in one line."""

from __future__ import annotations

import os
import threading
import time

import numpy as np
import pytest

from core.pose.keypoints import OTHER_SHOULDER, SHOULDER
from device.background import BACKGROUND_NICE
from device.camera.capture import CameraSource
from device.camera.detector import MediaPipePose
from device.camera.live import LivePose
from device.errors import PoseModelError


@pytest.fixture(scope="module")
def astronaut_clip(tmp_path_factory):
    from tests.astronaut import astronaut_clip

    return astronaut_clip(tmp_path_factory.mktemp("clip") / "astronaut.avi")


def wait_for(condition, timeout_s=30.0):
    deadline = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_keypoints_of_the_live_frames_are_published(astronaut_clip):
    camera = CameraSource(astronaut_clip).start()
    live = LivePose(camera, lambda: MediaPipePose("right", video=True)).start()
    try:
        wait_for(lambda: live.latest() is not None and live.latest().frame_index >= 5)
        result = live.latest()
        assert np.allclose(result.keypoints.xy_px[SHOULDER], [113, 240], atol=12)
        assert np.allclose(result.keypoints.xy_px[OTHER_SHOULDER], [306, 257], atol=12)
        assert result.time_s <= time.monotonic()
        wait_for(lambda: live.rate_fps > 0)
    finally:
        live.stop()
        camera.stop()
    assert not live.running
    assert live.error is None


def test_a_detector_that_cannot_start_is_said_in_one_line(astronaut_clip):
    camera = CameraSource(astronaut_clip).start()

    def refused():
        raise PoseModelError("model_complexity=2 (heavy model) is not bundled")

    live = LivePose(camera, refused).start()
    try:
        wait_for(lambda: not live.running)
    finally:
        live.stop()
        camera.stop()
    assert live.error == "live pose cannot start: model_complexity=2 (heavy model) is not bundled"
    assert live.latest() is None


def test_the_live_pose_worker_and_its_model_give_way_to_the_loop(astronaut_clip):
    """The worker lowers its own priority before it makes the model, so the model's
    threads run behind the loop too; the caller's thread keeps its priority."""
    seen = {}

    def make():
        tid = threading.get_native_id()
        seen["nice"] = os.getpriority(os.PRIO_PROCESS, tid)
        seen["cpus"] = os.sched_getaffinity(0)
        return MediaPipePose("right", video=True)

    mine = os.getpriority(os.PRIO_PROCESS, threading.get_native_id())
    camera = CameraSource(astronaut_clip).start()
    live = LivePose(camera, make).start()
    try:
        wait_for(lambda: live.latest() is not None)
    finally:
        live.stop()
        camera.stop()
    assert live.give_way_problems == []
    assert seen["nice"] == min(19, mine + BACKGROUND_NICE)
    assert len(seen["cpus"]) == max(1, len(os.sched_getaffinity(0)) - 1)
    assert os.getpriority(os.PRIO_PROCESS, threading.get_native_id()) == mine
