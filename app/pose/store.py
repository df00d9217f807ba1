"""The `/pose` group of a trial file: what the camera saw of the trial, written after it
(docs/data-format.md, "/pose"). Replaced whole when pose estimation runs again; the rest
of the file is never touched, so a trial file is as readable after a failed or repeated
run as before it.
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import TrialFileError
from core.pose.keypoints import KEYPOINT_NAMES
from core.pose.pipeline import PoseResult
from device.errors import RecordingError
from device.recording import h5views
from device.recording.trialfile import open_for_update, refuse_while_recording, utc_now_iso
from device.recording.trialfile.seal import open_room
from device.recording.trialfile.verify import Damaged, held

GROUP = "pose"
# dataset: (units, frame, description)
DATASETS = {
    "frame_time": ("s", "none", "each video frame's time on the trial's clock "
                   "(as /timeseries/time)"),
    "frame_index": ("1", "none", "the frame's position in the video file, 0-based"),
    "frame_keypoints_px": ("px", "image", "detected keypoints (shoulder, elbow, wrist, other "
                           "shoulder) in pixels, x right, y down; NaN where not visible"),
    "frame_visibility": ("1", "none", "the detector's visibility of each keypoint, 0-1"),
    "frame_keypoints": ("m", "global", "the same keypoints in the table plane; NaN in gaps"),
    "angle": ("rad", "arm", "camera's subject joint angles at each sample (eq. 3.16 "
              "convention); NaN in gaps"),
    "angle_isb": ("rad", "isb", "camera's subject joint angles for display (eq. 3.37-3.38)"),
    "shoulder": ("m", "global", "camera's shoulder position at each sample; NaN in gaps"),
    "shoulder_drift": ("m", "none", "distance of the camera's shoulder from its start position"),
    "solver_angle_camera_shoulder": ("rad", "arm", "the equation solver (eq. 3.28) rerun with "
                                     "the camera's shoulder instead of the fixed one"),
    "homography": ("1", "none", "3x3 map from pixels [u, v, 1] to the table plane [x, y, 1] "
                   "in m, up to scale"),
}


@dataclass(frozen=True, slots=True)
class PoseRun:
    """How the pose was obtained, kept beside it: the video file, the model, the settings."""

    video: str
    model: str
    min_visibility: float
    max_residual_mm: float
    drift_limit_m: float
    frame_index: np.ndarray
    keypoints_px: np.ndarray
    visibility: np.ndarray
    detect_every: int = 1
    """The detector ran on every k-th frame (app.pose.offline.estimate_pose)."""


def write_pose(path: str | os.PathLike, result: PoseResult, run: PoseRun) -> None:
    """Replace the trial file's `/pose` group with `result`. Refuses a file still being
    recorded."""
    path = Path(path)
    values = {
        "frame_time": result.frame_time_s,
        "frame_index": np.asarray(run.frame_index, dtype=np.int64),
        "frame_keypoints_px": np.asarray(run.keypoints_px, dtype=float),
        "frame_visibility": np.asarray(run.visibility, dtype=float),
        "frame_keypoints": result.keypoints_m,
        "angle": result.angle,
        "angle_isb": result.angle_isb,
        "shoulder": result.shoulder_m,
        "shoulder_drift": result.drift.drift_m,
        "solver_angle_camera_shoulder": result.solver_angle_camera_shoulder,
        "homography": result.homography.matrix,
    }
    attrs = {
        "created_utc": utc_now_iso(),
        "video": run.video,
        "model": run.model,
        "keypoints": json.dumps(list(KEYPOINT_NAMES)),
        "min_visibility": float(run.min_visibility),
        "detect_every": int(run.detect_every),
        "frames": int(result.frames),
        "frames_seen": int(result.frames_seen),
        "fit_method": result.homography.method,
        "fit_exact": np.uint8(result.homography.exact),
        "fit_residual_mm": float(result.homography.residual_mm),
        "fit_max_residual_mm": float(result.homography.max_residual_mm),
        "fit_limit_mm": float(run.max_residual_mm),
        "fit_inliers": int(result.homography.n_inliers),
        "shoulder_start_m": np.asarray(result.drift.start_m, dtype=float),
        "shoulder_max_drift_m": result.drift.max_drift_m,
        "shoulder_rms_drift_m": result.drift.rms_drift_m,
        "shoulder_offset_m": result.drift.offset_m,
        "shoulder_drift_limit_m": float(run.drift_limit_m),
        "shoulder_drift_exceeded": np.uint8(result.drift.exceeded),
        "shoulder_time_over_limit_s": result.drift.time_over_s,
    }
    for joint in result.errors:
        attrs.update(joint.to_dict("camera_vs_solver_"))
    for joint in result.errors_camera_shoulder:
        attrs.update(joint.to_dict("camera_vs_solver_camera_shoulder_"))
    try:
        with open_for_update(path, "/pose") as f:
            refuse_while_recording(f, path, "run pose estimation after the trial has ended")
            if GROUP in f:
                del f[GROUP]
            group = f.create_group(GROUP)
            for key, value in attrs.items():
                group.attrs[key] = value
            for name, value in values.items():
                units, frame, description = DATASETS[name]
                data = np.ascontiguousarray(value)
                ds = group.create_dataset(name, data=data, fletcher32=True,
                                          chunks=data.shape if data.size else None)
                ds.attrs["units"] = units
                ds.attrs["frame"] = frame
                ds.attrs["description"] = description
    except (OSError, RuntimeError, ValueError) as exc:
        raise RecordingError(f"cannot store the pose in {path}: {exc}. Check the disk has "
                             "space and the file is not open in another program") from exc


SHAPES = {
    "frame_time": ("F",), "frame_index": ("F",), "frame_keypoints_px": ("F", 4, 2),
    "frame_visibility": ("F", 4), "frame_keypoints": ("F", 4, 2), "angle": ("N", 2),
    "angle_isb": ("N", 2), "shoulder": ("N", 2), "shoulder_drift": ("N",),
    "solver_angle_camera_shoulder": ("N", 2), "homography": (3, 3),
}
"""Each dataset's shape: F the frames decoded, N the trial's samples (docs/data-format.md)."""


def read_pose(path: str | os.PathLike) -> dict | None:
    """The `/pose` group as {"attrs": {...}, name: array, ...}, or None when the trial has
    none. Compared with the file's seal (device.recording.trialfile.seal) and checked
    whoever wrote it: every dataset there, numbers of the shapes SHAPES gives."""
    path = Path(path)
    try:
        with held(path):  # one thread at a time in a trial file (verify.held)
            return _read(path)
    except Damaged as exc:
        raise TrialFileError(path, exc.problem, "Run `rehab pose` on the trial again, or "
                             "restore the file from the backup") from None
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
        detail = " ".join(str(exc).split())
        raise TrialFileError(path, f"its pose group cannot be read ({detail})",
                             "Run `rehab pose` on the trial again") from exc


def _read(path: Path) -> dict | None:
    with open_room(path, f"/{GROUP}") as opened:
        if opened is None:
            return None
        _, found, _ = opened
        group = found.groups.get(f"/{GROUP}")
        if group is None:
            raise Damaged("is damaged: /pose is not a group")
        out = {"attrs": {k: _plain(v) for k, v in h5views.items(group.attrs)}}
        for name in group:
            if f"/{GROUP}/{name}" not in found.datasets:
                raise Damaged(f"is damaged: /pose/{name} is not a dataset")
            out[name] = group[name][()]
        time = found.datasets.get("/timeseries/time")
        _check_shapes(out, None if time is None else time.shape[0])
        return out


def _check_shapes(group: dict, n_samples: int | None) -> None:
    """Every dataset of SHAPES there, of its shape, N the trial's samples, the frames'
    indices increasing from 0 or more."""
    sizes: dict[str, int] = {} if n_samples is None else {"N": n_samples}
    for name, shape in SHAPES.items():
        values = group.get(name)
        if not isinstance(values, np.ndarray):
            raise Damaged(f"is damaged: /pose/{name} is missing")
        kinds = "iu" if name == "frame_index" else "f"
        fits = values.dtype.kind in kinds and values.ndim == len(shape)
        for size, want in zip(values.shape, shape, strict=False):
            if isinstance(want, int):
                fits = fits and size == want
            else:
                fits = fits and sizes.setdefault(want, size) == size
        if not fits:
            wanted = ", ".join(map(str, shape))
            raise Damaged(f"is damaged: /pose/{name} holds {values.dtype} of shape "
                          f"{values.shape}, not ({wanted}{',' if len(shape) == 1 else ''}; "
                          f"N = {sizes.get('N', '?')} samples)")
    index = group["frame_index"]
    if index.size and (index[0] < 0 or (np.diff(index) <= 0).any()):
        raise Damaged("is damaged: /pose/frame_index is not frame numbers from 0 that only "
                      "increase")


def _plain(value):
    if isinstance(value, bytes):
        return value.decode()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value


def comparison_lines(group: dict | None) -> list[str]:
    """The camera against the solver in words for a report (degrees and centimetres):
    one line per joint, as Table 3.4, and one for the shoulder; [] without a pose."""
    if not group:
        return []
    a = group["attrs"]
    lines = []
    for joint in ("shoulder", "elbow"):
        rmse = a.get(f"camera_vs_solver_{joint}_rmse_rad", float("nan"))
        bias = a.get(f"camera_vs_solver_{joint}_bias_rad", float("nan"))
        lines.append(f"camera vs equation solver, {joint} (ISB): {math.degrees(rmse):.2f}° "
                     f"RMSE, {math.degrees(bias):+.2f}° bias (video {a.get('video', '?')}, "
                     "thesis Table 3.4's comparison)")
    drift = a.get("shoulder_max_drift_m", float("nan"))
    limit = a.get("shoulder_drift_limit_m", float("nan"))
    text = f"camera: the shoulder moved up to {100 * drift:.1f} cm during the trial"
    if a.get("shoulder_drift_exceeded"):
        text += (f", more than the {100 * limit:.1f} cm allowed: the solver's angles assume "
                 "it still")
    lines.append(text)
    return lines
