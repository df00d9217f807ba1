"""`rehab pose TRIAL`: pose estimation of a recorded trial from its video (app.pose.offline),
the result written into the trial file's `/pose` group, and the camera against the
equation solver printed per joint as Table 3.4 (RMSE and bias), with the shoulder's drift.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

from app.cli.common import (
    CommandError,
    ProgressBar,
    input_file,
    registry_for,
    rewritten_trial,
    trial_id_or_none,
)
from device.safeinput import MAX_TEXT_BYTES

# Without a terminal, progress is a line at every tenth.
_TENTHS = 10


def add_pose_command(commands) -> None:
    parser = commands.add_parser(
        "pose", help="joint angles from a trial's video (MediaPipe Pose), against the solver",
        description="Run pose estimation on a recorded trial's video (trial.mp4 beside the "
                    "trial file, with its timestamps), write the camera's joint angles and "
                    "shoulder track into the trial file's /pose group, and compare them with "
                    "the equation solver's angles (RMSE and bias per joint, as Table 3.4).")
    parser.add_argument("trial", help="the trial file (.h5), or a registered trial's id")
    parser.add_argument("--video", help="the video (default: the .mp4 or .avi beside the trial)")
    parser.add_argument("--marks", help="CSV of four or more marked points u_px,v_px,x_m,y_m "
                                        "for the camera map (default: fitted from the handle)")
    parser.add_argument("--reference", help="CSV of reference angles (frame or time_s, "
                                            "shoulder_deg, elbow_deg; ISB, e.g. a goniometer's): "
                                            "the camera's and the solver's error against it")
    parser.add_argument("--drift-limit-cm", type=float, default=3.0,
                        help="warn when the shoulder moves further than this (default 3)")
    parser.add_argument("--max-residual-mm", type=float, default=15.0,
                        help="refuse a camera map whose residual exceeds this (default 15)")
    parser.add_argument("--min-visibility", type=float, default=0.5,
                        help="keypoints the model sees less surely are gaps (default 0.5)")
    parser.add_argument("--every", type=int, default=1, metavar="K",
                        help="the detector on every K-th frame only (1-10, default 1): for a "
                             "computer too slow for the model at the camera's rate")
    parser.add_argument("--video-start-s", type=float,
                        help="the trial time of the video's first frame, for a trial file "
                             "that does not record its clock's start (simulated runs)")
    parser.set_defaults(func=cmd_pose)


def cmd_pose(args: argparse.Namespace) -> int:
    from app.pose.offline import MAX_DETECT_EVERY, estimate_pose, read_marks
    from device.camera.detector import MediaPipePose

    for name, value in (("--drift-limit-cm", args.drift_limit_cm),
                        ("--max-residual-mm", args.max_residual_mm)):
        if not (math.isfinite(value) and value > 0):
            raise CommandError(f"{name} {value:g}: give a positive number")
    if not 1 <= args.every <= MAX_DETECT_EVERY:
        raise CommandError(f"--every {args.every}: give a whole number of frames from 1 to "
                           f"{MAX_DETECT_EVERY}")
    if not 0.0 <= args.min_visibility <= 1.0:
        raise CommandError(f"--min-visibility {args.min_visibility:g}: give a number from 0 "
                           "to 1")
    if args.video_start_s is not None and not math.isfinite(args.video_start_s):
        raise CommandError(f"--video-start-s {args.video_start_s}: give a finite time in s")
    path = _trial_path(args)
    # every file named is a plain file of a sensible size before any reader opens it
    marks = input_file(args.marks, "--marks", max_bytes=MAX_TEXT_BYTES) \
        if args.marks is not None else None
    reference = input_file(args.reference, "--reference", max_bytes=MAX_TEXT_BYTES) \
        if args.reference is not None else None
    video = input_file(args.video, "--video") if args.video is not None else None
    homography = read_marks(marks) if marks is not None else None
    progress = _Progress(f"pose {path.name}")
    # a registered trial's file gets /pose after its end: its checksum follows
    with rewritten_trial(args, args.trial, path, "the camera's pose"):
        outcome = estimate_pose(
            path, lambda side: MediaPipePose(side, video=True),
            video_path=video,
            homography=homography,
            reference=reference,
            video_start_s=args.video_start_s, min_visibility=args.min_visibility,
            max_residual_mm=args.max_residual_mm, drift_limit_m=args.drift_limit_cm / 100.0,
            progress=progress.update, detect_every=args.every)
    progress.done()
    _print(outcome)
    return 0


def _trial_path(args) -> Path:
    text = args.trial.strip()
    if not text:
        raise CommandError("give the trial file (.h5) or a registered trial's id")
    number = trial_id_or_none(text)
    if number is not None:
        registry = registry_for(args)
        return registry.trial_path(registry.trial(number))
    return input_file(args.trial, "trial file")


class _Progress:
    """The bar on a terminal; a line at every tenth otherwise (a log, a pipe)."""

    def __init__(self, label: str) -> None:
        self.label = label
        self.bar = ProgressBar(label) if sys.stderr.isatty() else None
        self.shown = -1

    def update(self, fraction: float) -> None:
        if self.bar is not None:
            self.bar.update(fraction)
            return
        tenth = int(fraction * _TENTHS)
        if tenth != self.shown:
            self.shown = tenth
            sys.stderr.write(f"{self.label}: {100 * tenth // _TENTHS} % of the frames\n")

    def done(self) -> None:
        if self.bar is not None:
            self.bar.done()


def _deg(value: float) -> str:
    return "–" if not math.isfinite(value) else f"{math.degrees(value):.2f}°"


def _print(outcome) -> None:
    from app.pose.offline import reference_lines

    r = outcome.result
    # with --every the model saw only some of the video's frames: say both, as a file of
    # 264 frames read as "88 frames of trial.mp4"
    shown = (f"{r.frames} frames" if r.frames >= outcome.video.frames else
             f"{r.frames} of the {outcome.video.frames} frames")
    print(f"{outcome.trial.path.name}: {shown} of {outcome.video.path.name} through the "
          f"model, {r.frames_seen} with the whole arm seen")
    print(f"camera map: {r.homography.describe()}")
    print("camera vs equation solver (ISB angles, camera − solver):")
    print(f"  {'joint':<9}{'RMSE':>9}{'bias':>9}{'samples':>9}")
    for joint in r.errors:
        print(f"  {joint.joint:<9}{_deg(joint.rmse_rad):>9}{_deg(joint.bias_rad):>9}"
              f"{joint.n:>9}")
    d = r.drift
    print(f"shoulder: drift up to {100 * d.max_drift_m:.1f} cm (RMS {100 * d.rms_drift_m:.1f} "
          f"cm), {100 * d.offset_m:.1f} cm from where the solver assumes it")
    warning = d.warning()
    if warning:
        moved = r.errors_camera_shoulder
        print(f"warning: {warning}")
        print("  camera vs solver on the camera's shoulder: "
              + ", ".join(f"{j.joint} {_deg(j.rmse_rad)} RMSE" for j in moved))
    if outcome.reference_errors:
        print("against the reference angles (other − reference):")
        for line in reference_lines(outcome.reference_errors):
            print(f"  {line}")
    print(f"written to {outcome.trial.path} (/pose)")
