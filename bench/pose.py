"""Pose estimation: throughput of the offline pipeline at 640×480 on one core, and the
camera's agreement with the equation solver on a filmed simulated trial.

Run: .venv/bin/python bench/pose.py [--frames N] [--seeds S] [--all-cores]
                                    [--only throughput|rmse] [--every K]
Throughput: a 640×480 MJPG video of N frames (default 600) of the astronaut photograph
(scikit-image, a real upper body) drifting across the picture is decoded and run through
MediaPipe Pose 0.10.14 in tracking mode, as `rehab pose` does; then the geometry after
the detector (camera map, angles, 2 ms series, comparison) runs on a simulated trial
filmed with the same number of frames. The process is pinned to one core. Goal: the
whole pipeline at 45 fps or more. `--every K` runs the detector on every K-th frame only
(`rehab pose --every K`), for both figures.
RMSE: the thesis's D (5 repetitions, 20 s) simulated, filmed at 30 fps through a known
tilted camera with 1, 2 and 4 px of noise, 5 % of frames dropped, 3 % of keypoints unseen
and 2 % of wrists wrong, over S seeds (default 5). Goal: ≤ 1° per joint at 2 px (the
thesis's pose estimator was 0.84° from the solver, Table 3.4).
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

GOAL_FPS = 45.0
GOAL_DEG = 1.0


def astronaut_video(path: Path, n: int) -> Path:
    import cv2
    from skimage import data

    person = cv2.resize(data.astronaut()[:, :, ::-1], (400, 400))
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (640, 480))
    for k in range(n):
        frame = np.full((480, 640, 3), 60, np.uint8)
        x = int(120 + 80 * np.sin(2 * np.pi * k / 120))
        y = int(40 + 20 * np.sin(2 * np.pi * k / 90))
        frame[y:y + 400, x:x + 400] = person
        writer.write(frame)
    writer.release()
    return path


def throughput(n: int, cores: str, every: int = 1) -> None:
    import cv2

    from app.pose.synthetic import film
    from app.trials.headless import save, simulate
    from app.trials.reader import read_trial
    from core.pose.pipeline import pose_from_keypoints
    from core.pose.timebase import frame_times
    from core.trial import THESIS_SUBJECT
    from device.camera.detector import MediaPipePose

    cv2.setNumThreads(1)
    with tempfile.TemporaryDirectory() as folder:
        video = astronaut_video(Path(folder) / "clip.avi", n)
        started = time.perf_counter()
        capture = cv2.VideoCapture(str(video))
        decoded = 0
        while capture.read()[0]:
            decoded += 1
        capture.release()
        decode_s = time.perf_counter() - started

        made = time.perf_counter()
        detector = MediaPipePose("right", video=True)
        made_s = time.perf_counter() - made
        per_frame = []
        seen = 0
        capture = cv2.VideoCapture(str(video))
        started = time.perf_counter()
        cpu_started = time.process_time()
        frame = -1
        while True:
            ok, image = capture.read()
            if not ok:
                break
            frame += 1
            if frame % every:
                continue
            t0 = time.perf_counter()
            k = detector.detect(image)
            per_frame.append(time.perf_counter() - t0)
            seen += bool(np.isfinite(k.gapped()[0]).all())
        detect_s = time.perf_counter() - started
        detect_cpu_s = time.process_time() - cpu_started
        capture.release()
        detector.close()

        # the geometry after the detector, on a trial filmed with about as many frames
        reps = max(1, round(n / 30.0 / 4.0 / 1.06))
        path = Path(folder) / "trial.h5"
        save(simulate(THESIS_SUBJECT.replace(repetitions=reps), seed=1), path)
        trial = read_trial(path)
        filmed = thinned(film(trial, seed=0), every)
        c = trial.channels
        started = time.perf_counter()
        cpu_started = time.process_time()
        ft = frame_times(filmed.stamps_s, filmed.origin_s, c["wall_time"], c["time"])
        pose_from_keypoints(trial.parameters.arm(), c["time"], c["position"],
                            c["subject_angle"], ft, filmed.keypoints_px, filmed.visibility)
        geometry_s = time.perf_counter() - started
        geometry_cpu_s = time.process_time() - cpu_started
        geometry_frames = filmed.stamps_s.size * every  # the video's frames it stands for

    ms = 1000 * np.asarray(per_frame)
    total_s = detect_s + geometry_s * decoded / geometry_frames
    print(f"pose throughput, 640×480, {cores} ({decoded} frames, the detector on "
          f"{len(per_frame)} of them, person seen in {seen})")
    print(f"  MediaPipe Pose, made and warmed up   {1000 * made_s:7.0f} ms")
    print(f"  decoding alone                      {decoded / decode_s:7.0f} fps")
    print(f"  detector (tracking mode)            {len(per_frame) / sum(per_frame):7.1f} fps "
          f"(median {np.median(ms):.1f} ms, p99 {np.percentile(ms, 99):.1f} ms)")
    print(f"  geometry after the detector         {geometry_frames / geometry_s:7.0f} fps "
          f"({geometry_frames} frames, {1000 * geometry_s:.0f} ms)")
    fps = decoded / total_s
    print(f"  whole pipeline (decode + detect + geometry) {fps:6.1f} fps  "
          f"goal >= {GOAL_FPS:g}: {'met' if fps >= GOAL_FPS else 'NOT met'}")
    # on a shared machine the wall clock counts other processes' turns on the core too;
    # the CPU time is this process's own
    cpu_fps = decoded / (detect_cpu_s + geometry_cpu_s * decoded / geometry_frames)
    print(f"  whole pipeline by its own CPU time          {cpu_fps:6.1f} fps "
          f"(wall/CPU {total_s / (detect_cpu_s + geometry_cpu_s * decoded / geometry_frames):.2f}"
          f"; over 1 the core was shared)")


def thinned(filmed, every: int):
    """The film as the detector sees it on every `every`-th frame only."""
    import dataclasses

    if every == 1:
        return filmed
    keep = slice(0, None, every)
    return dataclasses.replace(filmed, stamps_s=filmed.stamps_s[keep],
                               keypoints_px=filmed.keypoints_px[keep],
                               visibility=filmed.visibility[keep],
                               true_frame_t_s=filmed.true_frame_t_s[keep])


def agreement(seeds: int, every: int = 1) -> None:
    from app.pose.synthetic import film
    from app.trials.headless import save, simulate
    from app.trials.reader import read_trial
    from core.pose.pipeline import pose_from_keypoints
    from core.pose.timebase import frame_times
    from core.trial import THESIS_SUBJECT

    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "trial.h5"
        save(simulate(THESIS_SUBJECT, patient="healthy", seed=1), path)
        trial = read_trial(path)
    c = trial.channels
    arm = trial.parameters.arm()
    print(f"camera vs solver, the thesis's D ({trial.n_samples} samples), {seeds} seeds, "
          f"the detector on every {every} frame(s); ISB angles, camera − solver")
    print(f"  {'noise':>6} {'shoulder RMSE':>14} {'elbow RMSE':>11} {'shoulder bias':>14} "
          f"{'elbow bias':>11} {'map residual':>13}")
    for noise in (1.0, 2.0, 4.0):
        rows = []
        for seed in range(seeds):
            filmed = thinned(film(trial, noise_px=noise, seed=seed), every)
            ft = frame_times(filmed.stamps_s, filmed.origin_s, c["wall_time"], c["time"])
            r = pose_from_keypoints(arm, c["time"], c["position"], c["subject_angle"], ft,
                                    filmed.keypoints_px, filmed.visibility)
            rows.append([np.degrees(r.errors[0].rmse_rad), np.degrees(r.errors[1].rmse_rad),
                         np.degrees(r.errors[0].bias_rad), np.degrees(r.errors[1].bias_rad),
                         r.homography.residual_mm])
        a = np.asarray(rows)
        worst = a[:, :2].max()
        mean = a.mean(axis=0)
        note = f"  worst {worst:.2f}°" + (f", goal <= {GOAL_DEG:g}°: "
                                           f"{'met' if worst <= GOAL_DEG else 'NOT met'}"
                                           if noise == 2.0 else "")
        print(f"  {noise:4.0f}px {mean[0]:13.2f}° {mean[1]:10.2f}° {mean[2]:13.2f}° "
              f"{mean[3]:10.2f}° {mean[4]:10.1f} mm{note}")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=600)
    parser.add_argument("--seeds", type=int, default=5)
    parser.add_argument("--all-cores", action="store_true",
                        help="do not pin the process to one core")
    parser.add_argument("--only", choices=("throughput", "rmse"))
    parser.add_argument("--every", type=int, default=1, help="the detector on every K-th frame")
    args = parser.parse_args()
    if hasattr(os, "sched_setaffinity") and not args.all_cores:
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})
    if args.only in (None, "throughput"):
        throughput(args.frames, "all cores" if args.all_cores else "one core", args.every)
    if args.only in (None, "rmse"):
        agreement(args.seeds, args.every)


if __name__ == "__main__":
    main()
