"""Live pose beside a running trial: the loop's lateness without and with MediaPipe on the
live camera, and the rate the live pose keeps up with.

Run: .venv/bin/python bench/pose_live.py [--seconds 20]
Runs the real loop process (simulator, healthy virtual patient, thesis D, recorder writing
the trial file) for `--seconds`, `--pairs` times three ways, interleaved: with this
process only draining the ring; with a camera (a 640×480 video of the astronaut
photograph played at 30 fps, as a camera delivers it) and `device.camera.live.LivePose`
running MediaPipe on its newest frames at the window's priority; and the same giving way
to the loop as the Video tab's *Show the pose* does (device.background: nice +10, off the
loop's CPU). Prints the loop's lateness p50 / p99 / max and late share for each run, and
the live pose's rate. Goal: the loop's lateness unchanged. `--camera-fps` (default 30)
plays the video faster: at 120 the detector runs flat out on a core, as it does on a
host where one picture takes longer than a camera period.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.camera.capture import CameraSource
from device.camera.detector import MediaPipePose
from device.camera.live import LivePose
from device.loop.client import DeviceClient
from device.loop.messages import BackendConfig
from device.loop.pipeline import PERIOD_S
from device.recording.messages import RecorderNotice
from device.recording.trialfile import SubjectInfo


def astronaut_video(path: Path, seconds: float, fps: float = 30.0) -> Path:
    import cv2
    from skimage import data

    person = cv2.resize(data.astronaut()[:, :, ::-1], (400, 400))
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), fps, (640, 480))
    for k in range(int(fps * (seconds + 5))):
        frame = np.full((480, 640, 3), 60, np.uint8)
        x = int(120 + 80 * np.sin(2 * np.pi * k / 120))
        frame[40:440, x:x + 400] = person
        writer.write(frame)
    writer.release()
    return path


def run(seconds: float, folder: Path, label: str, video: Path | None,
        give_way: bool = True) -> dict:
    params = THESIS_SUBJECT.replace(repetitions=max(1, round(seconds / 4.0)))
    path = folder / f"{label}.h5"
    camera = live = None
    if video is not None:
        camera = CameraSource(video).start()
        live = LivePose(camera, lambda: MediaPipePose("right", video=True),
                        give_way=give_way).start()
        while live.latest() is None and live.error is None:
            time.sleep(0.05)  # the model started before the trial, as in the window
    rate = []
    with DeviceClient() as client:
        assert client.build(params, BackendConfig()).ok
        assert client.connect().ok
        time.sleep(0.5)
        assert client.start_trial(str(path), SubjectInfo.from_parameters("PBENCH0", params)).ok
        seen: list = []
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            client.live_records()
            seen += client.events(0.05)
            if live is not None:
                rate.append(live.rate_fps)
        if not any(isinstance(e, RecorderNotice) and e.kind == "closed" for e in seen):
            client.wait_for(lambda e: isinstance(e, RecorderNotice) and e.kind == "closed", 30)
    if live is not None:
        live.stop()
        camera.stop()
    data = read_trial(path)
    lateness = data.channels["lateness"][data.channels["phase"] > 0].astype(float)
    return {"label": label, "p50": 1e3 * np.percentile(lateness, 50),
            "p99": 1e3 * np.percentile(lateness, 99), "max": 1e3 * lateness.max(),
            "late": 100 * np.mean(lateness > PERIOD_S),
            "pose_fps": float(np.median(rate[len(rate) // 4:])) if rate else float("nan")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--camera-fps", type=float, default=30.0)
    parser.add_argument("--pairs", type=int, default=1,
                        help="how many times to run the three (interleaved)")
    args = parser.parse_args()
    runs = []
    with tempfile.TemporaryDirectory() as folder:
        video = astronaut_video(Path(folder) / "camera.avi", args.seconds, args.camera_fps)
        for n in range(args.pairs):
            runs += [run(args.seconds, Path(folder), f"alone{n}", None),
                     run(args.seconds, Path(folder), f"same{n}", video, give_way=False),
                     run(args.seconds, Path(folder), f"giving{n}", video)]
    labels = {"alone": "alone", "same": "pose, window's priority",
              "giving": "pose, giving way"}
    print(f"loop lateness over {args.seconds:g} s trials, without and with live pose "
          f"(camera at {args.camera_fps:g} fps)")
    print(f"{'run':<26}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>10}{'late %':>8}{'pose fps':>10}")
    for r in runs:
        name = labels[r["label"].rstrip("0123456789")]
        print(f"{name:<26}{r['p50']:9.3f}{r['p99']:9.3f}{r['max']:10.1f}{r['late']:8.3f}"
              f"{r['pose_fps']:10.1f}")


if __name__ == "__main__":
    main()
