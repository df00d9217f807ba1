"""Pose estimation of a recorded trial, after it (Appendix A.5.1): its video through the
detector frame by frame, the geometry of core.pose, and the result into the trial file's
`/pose` group.

Everything that can make a video unusable is checked before the trial file is opened for
writing, and said in one line (VideoError); a failed run leaves the file as it was.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.pose.store import PoseRun, read_pose, write_pose
from app.trials.reader import TrialData, read_trial
from core.errors import ParameterError
from core.pose.angles import DEFAULT_DRIFT_LIMIT_M
from core.pose.compare import JointError, ReferenceAngles, joint_errors, read_reference_csv
from core.pose.homography import DEFAULT_MAX_RESIDUAL_MM, Homography, fit_from_points
from core.pose.keypoints import DEFAULT_MIN_VISIBILITY, ELBOW, SHOULDER, WRIST
from core.pose.pipeline import PoseResult, pose_from_keypoints
from core.pose.timebase import covered_span, frame_times, resample
from device.camera.detector import MEDIAPIPE_VERSION, PoseDetector
from device.camera.video import VideoInfo, frames, open_video
from device.errors import VideoError

Progress = Callable[[float], None]
VIDEO_SUFFIXES = (".mp4", ".avi")
# The video may start or end this much inside the trial (the camera starts recording
# when the trial begins, a frame or two late); more is a video shorter than the trial.
COVERAGE_SLACK_S = 1.0
# Smaller pictures than this hold too few pixels per arm for the detector.
MIN_FRAME_SIZE = (160, 120)
ORIGIN_KEY = "wall_time_origin_monotonic_s"


@dataclass(frozen=True, slots=True)
class OfflinePose:
    """The result of `estimate_pose`: the pipeline's result, the video used, and against a
    reference when one was given."""

    trial: TrialData
    video: VideoInfo
    result: PoseResult
    reference_errors: dict[str, tuple[JointError, JointError]] | None


MAX_DETECT_EVERY = 10
"""The detector on at least every 10th frame: 3 a second at 30 fps, still several a
repetition of the thesis's 4 s D."""


def default_video(trial_path: Path) -> Path:
    """The video the console records beside a trial: trial.mp4 (or .avi)."""
    for suffix in VIDEO_SUFFIXES:
        candidate = trial_path.with_suffix(suffix)
        if candidate.is_file():
            return candidate
    return trial_path.with_suffix(VIDEO_SUFFIXES[0])


def read_marks(path: str | os.PathLike) -> Homography:
    """Four or more marked points as CSV `u_px,v_px,x_m,y_m` (the picture's pixels and the
    mark's measured position in the global frame) -> the camera map."""
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8") as f:
            rows = [r for r in csv.reader(f) if r and any(c.strip() for c in r)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise VideoError(f"marked points {path} cannot be read ({exc})") from exc
    if not rows or [c.strip() for c in rows[0]] != ["u_px", "v_px", "x_m", "y_m"]:
        raise VideoError(f"marked points {path}: the first line must be u_px,v_px,x_m,y_m")
    try:
        values = np.array([[float(c) for c in r] for r in rows[1:]], dtype=float)
    except ValueError:
        raise VideoError(f"marked points {path}: every row must be four numbers") from None
    if values.ndim != 2 or values.shape[1] != 4:
        raise VideoError(f"marked points {path}: every row must be four numbers")
    return fit_from_points(values[:, :2], values[:, 2:])


def estimate_pose(
    trial_path: str | os.PathLike,
    detector: PoseDetector | Callable[[str], PoseDetector],
    *,
    video_path: str | os.PathLike | None = None,
    homography: Homography | None = None,
    reference: ReferenceAngles | str | os.PathLike | None = None,
    video_start_s: float | None = None,
    min_visibility: float = DEFAULT_MIN_VISIBILITY,
    max_residual_mm: float = DEFAULT_MAX_RESIDUAL_MM,
    drift_limit_m: float = DEFAULT_DRIFT_LIMIT_M,
    model_name: str = f"MediaPipe Pose {MEDIAPIPE_VERSION}, full model (complexity 1)",
    progress: Progress | None = None,
    write: bool = True,
    detect_every: int = 1,
) -> OfflinePose:
    """Run pose estimation on a closed trial and its video; write `/pose` when `write`.

    `detector`: a PoseDetector, or a function of the arm's side that makes one (made only
    once the video and the trial have been checked). `video_start_s`: the trial time of
    the video's first frame, for a trial file without the loop's wall-time origin.
    `detect_every`: run the detector on every k-th frame only (1–MAX_DETECT_EVERY), for a
    computer too slow for the model at the camera's rate: the others are left out as a
    dropped frame is, and the 2 ms series is interpolated between the frames seen
    (bench/pose.py --every measures what it costs in agreement)."""
    if isinstance(detect_every, bool) or not isinstance(detect_every, int) or \
            not 1 <= detect_every <= MAX_DETECT_EVERY:
        raise ParameterError("detect_every", detect_every,
                             f"a whole number of frames from 1 to {MAX_DETECT_EVERY}")
    trial_path = Path(trial_path)
    trial = read_trial(trial_path)
    _check_trial(trial)
    video = open_video(video_path if video_path is not None else default_video(trial_path))
    if video.width < MIN_FRAME_SIZE[0] or video.height < MIN_FRAME_SIZE[1]:
        raise VideoError(f"video {video.path} is {video.width}×{video.height} px; pose "
                         f"estimation needs at least {MIN_FRAME_SIZE[0]}×{MIN_FRAME_SIZE[1]}")
    stamps_t = _frame_trial_times(trial, video, video_start_s)
    _check_coverage(trial, video, stamps_t)
    if isinstance(reference, str | os.PathLike):
        reference = read_reference_csv(reference)
    if isinstance(detector, type) or not hasattr(detector, "detect"):
        detector = detector(trial.parameters.side)  # a factory, or the detector's class
    index, px, vis = _detect(video, detector, progress, detect_every)
    keep = index < stamps_t.size
    index, px, vis = index[keep], px[keep], vis[keep]
    c = trial.channels
    result = pose_from_keypoints(
        trial.parameters.arm(), c["time"], c["position"], c["subject_angle"],
        stamps_t[index], px, vis, homography=homography, min_visibility=min_visibility,
        max_residual_mm=max_residual_mm, drift_limit_m=drift_limit_m)
    _check_arm_seen(result, video)
    reference_errors = None
    if reference is not None:
        def times_of(frames: np.ndarray) -> np.ndarray:
            if frames.max() >= stamps_t.size:
                raise VideoError(f"the reference names frame {int(frames.max())}, but the "
                                 f"video has {stamps_t.size} frames")
            return stamps_t[frames]

        reference_errors = _against_reference(trial, result.angle_isb, reference, times_of)
    if write:
        write_pose(trial_path, result, PoseRun(video.path.name, model_name, min_visibility,
                                               max_residual_mm, drift_limit_m, index, px, vis,
                                               detect_every))
    return OfflinePose(trial, video, result, reference_errors)


def _check_arm_seen(result: PoseResult, video: VideoInfo) -> None:
    """Refuse a run that gives no angle at all: with marked points no wrist is needed to
    fit the camera, so a video in which the model never saw the whole arm (a wrong camera,
    the arm out of the picture, the wrist always off the handle) got as far as writing an
    empty /pose and printing dashes, exit 0."""
    if result.frames_seen > 0:
        return
    seen = np.isfinite(result.keypoints_m).all(axis=2).sum(axis=0)
    raise VideoError(
        f"video {video.path.name}: the whole arm is seen in none of its {result.frames} "
        f"frames (the shoulder in {seen[SHOULDER]}, the elbow in {seen[ELBOW]}, the wrist "
        f"on the handle in {seen[WRIST]}), so it gives no angles; check that the camera "
        "sees the patient's arm and the handle")


def _check_trial(trial: TrialData) -> None:
    if not trial.closed:
        raise VideoError(f"trial {trial.path} is still being recorded (or was left open by a "
                         "crash and not finished yet); run pose estimation after it ends")
    if trial.parameters is None:
        raise VideoError(f"trial {trial.path} has no readable parameters, so the subject's "
                         "arm is unknown")
    missing = [n for n in ("time", "wall_time", "position", "subject_angle")
               if n not in trial.channels]
    if missing:
        raise VideoError(f"trial {trial.path} lacks the channel {missing[0]}")
    if trial.n_samples < 2:
        raise VideoError(f"trial {trial.path} holds {trial.n_samples} samples; nothing to "
                         "compare the video with")


def _frame_trial_times(trial: TrialData, video: VideoInfo, video_start_s) -> np.ndarray:
    c = trial.channels
    if video_start_s is not None:
        start = float(video_start_s)
        if not math.isfinite(start):
            raise VideoError(f"the video's start time {video_start_s!r} is not a number")
        return start + (video.stamps_s - video.stamps_s[0])
    origin = trial.summary.get(ORIGIN_KEY)
    if origin is None or not math.isfinite(float(origin)):
        raise VideoError(
            f"trial {trial.path} does not record when its clock started on the camera's "
            "clock (a simulated run, or an older console); give the trial time of the "
            "video's first frame (--video-start-s)")
    return frame_times(video.stamps_s, float(origin), c["wall_time"], c["time"])


def _check_coverage(trial: TrialData, video: VideoInfo, stamps_t: np.ndarray) -> None:
    t = trial.channels["time"]
    late, early = covered_span(stamps_t, t)
    if late > COVERAGE_SLACK_S or early > COVERAGE_SLACK_S:
        raise VideoError(
            f"video {video.path.name} covers the trial from {stamps_t[0]:.1f} s to "
            f"{stamps_t[-1]:.1f} s, but the trial runs from {t[0]:.1f} s to {t[-1]:.1f} s: "
            "the video is shorter than the trial (or belongs to another trial)")


def _detect(video: VideoInfo, detector: PoseDetector, progress: Progress | None,
            every: int = 1):
    index, px, vis = [], [], []
    total = max(video.frames, 1)
    decoded = 0
    try:
        for i, image in frames(video):
            decoded = i + 1
            if i % every:
                continue  # decoded all the same: a damaged file is found where it breaks
            k = detector.detect(image)
            index.append(i)
            px.append(k.xy_px)
            vis.append(k.visibility)
            if progress is not None:
                progress(min(1.0, (i + 1) / total))
    finally:
        detector.close()
    if len(index) < 2:
        raise VideoError(f"video {video.path} decodes to {len(index)} frame(s); the file is "
                         "damaged or the recording was cut short")
    if decoded < video.frames - 1:
        raise VideoError(f"video {video.path} stops decoding at frame {decoded} of "
                         f"{video.frames}: the file is damaged (cut short while recorded?)")
    return np.array(index), np.array(px, dtype=float), np.array(vis, dtype=float)


def compare_with_reference(trial_path: str | os.PathLike,
                           reference: ReferenceAngles | str | os.PathLike
                           ) -> dict[str, tuple[JointError, JointError]]:
    """Thesis Table 3.4 after the fact: the solver's and the camera's angles (the trial's
    stored /pose) against reference angles from a goniometer or motion capture, for a
    trial `rehab pose` has already run on. A reference by frame is placed with the
    frames' times the pose run kept."""
    trial = read_trial(trial_path)
    _check_trial(trial)
    pose = read_pose(trial_path)
    if pose is None:
        raise VideoError(f"trial {Path(trial_path).name} has no camera angles yet: run "
                         "`rehab pose` on it (with its video) first")
    if isinstance(reference, str | os.PathLike):
        reference = read_reference_csv(reference)
    kept, times = np.asarray(pose["frame_index"]), np.asarray(pose["frame_time"])

    def times_of(frames: np.ndarray) -> np.ndarray:
        at = np.minimum(np.searchsorted(kept, frames), kept.size - 1)
        missing = frames[kept[at] != frames]
        if missing.size:
            every = int(pose["attrs"].get("detect_every", 1))
            which = f"every {every}th frame from" if every > 1 else "frames"
            raise VideoError(f"the reference names frame {int(missing[0])}, but the pose run "
                             f"kept {which} {int(kept[0])}–{int(kept[-1])} of the video; give "
                             "the reference by time_s, or run `rehab pose` on every frame")
        return times[at]

    return _against_reference(trial, pose["angle_isb"], reference, times_of)


def reference_lines(errors: dict[str, tuple[JointError, JointError]]) -> list[str]:
    """The comparison with reference angles in words, one line per source (degrees)."""
    return [f"{source}: " + ", ".join(
        f"{j.joint} {math.degrees(j.rmse_rad):.2f}° RMSE, {math.degrees(j.bias_rad):+.2f}° bias "
        f"({j.n} samples)" for j in joints) for source, joints in errors.items()]


def _against_reference(trial, camera_isb: np.ndarray, reference: ReferenceAngles,
                       times_of: Callable[[np.ndarray], np.ndarray]):
    """Camera and solver against reference ISB angles, at the reference's instants
    (`times_of` places a reference given by video frame on the trial's clock)."""
    c = trial.channels
    at = times_of(reference.frame) if reference.frame is not None else reference.time_s
    arm = trial.parameters.arm()
    solver = arm.isb_angles(resample(c["time"], c["subject_angle"], at, angles=True,
                                     max_gap_s=10 * trial.sample_period_s))
    camera = resample(c["time"], camera_isb, at, angles=True,
                      max_gap_s=10 * trial.sample_period_s)
    return {"solver": joint_errors(reference.isb_rad, solver),
            "camera": joint_errors(reference.isb_rad, camera)}
