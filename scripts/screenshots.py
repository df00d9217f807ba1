"""Screenshots of every tab with realistic simulated data, for the docs and for review.

    QT_QPA_PLATFORM=offscreen .venv/bin/python scripts/screenshots.py [--out docs/screenshots]

Everything runs in a temporary data folder: a registry with one fictional patient,
a few simulated trials on the thesis's D (healthy, then weak, then healthy at a
harder setting), a synthetic camera video. Nothing touches the clinic's data.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
if not os.environ.get("DISPLAY") and not os.environ.get("WAYLAND_DISPLAY"):
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")

import cv2  # noqa: E402
import numpy as np  # noqa: E402
from PySide6.QtWidgets import QApplication  # noqa: E402

from app.records.datadir import DataDir  # noqa: E402
from app.records.registry import Registry  # noqa: E402
from app.trials.headless import save, simulate  # noqa: E402
from core.trial import THESIS_AS_PRINTED, THESIS_SUBJECT  # noqa: E402
from ui import theme  # noqa: E402
from ui.tabs import (  # noqa: E402
    AnglesTab,
    ForceTab,
    InstructionsTab,
    ParametersTab,
    ProgressTab,
    RegistrationTab,
    ReplayTab,
    ReportTab,
    TorquesTab,
    TrajectoryTab,
    VideoTab,
)
from ui.views.trialview import TrialView  # noqa: E402

SIZE = (1280, 800)


def wait(app: QApplication, done, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not done():
        if time.monotonic() > deadline:
            raise TimeoutError("a tab did not finish in time")
        app.processEvents()
        time.sleep(0.01)
    app.processEvents()


def settle(app: QApplication, seconds: float = 0.2) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        app.processEvents()
        time.sleep(0.01)


def shoot(app: QApplication, widget, path: Path) -> Path:
    widget.resize(*SIZE)
    widget.show()
    settle(app)
    widget.grab().save(str(path))
    print(f"wrote {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}")
    return path


def synthetic_video(path: Path, frames: int = 90) -> Path:
    """A 640×480 clip of a two-segment 'arm' sweeping over a table, at 30 fps."""
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter.fourcc(*"MJPG"), 30.0, (640, 480))
    shoulder = np.array([320, 60])
    for k in range(frames):
        image = np.full((480, 640, 3), (205, 200, 190), np.uint8)
        cv2.rectangle(image, (60, 200), (580, 460), (150, 120, 90), -1)  # the table
        a = 0.9 + 0.4 * np.sin(2 * np.pi * k / frames)
        elbow = shoulder + (170 * np.array([np.cos(a + 0.6), np.sin(a + 0.6)])).astype(int)
        hand = elbow + (160 * np.array([np.cos(a - 0.5), np.sin(a - 0.5)])).astype(int)
        cv2.line(image, tuple(map(int, shoulder)), tuple(map(int, elbow)), (60, 60, 200), 18)
        cv2.line(image, tuple(map(int, elbow)), tuple(map(int, hand)), (60, 160, 230), 14)
        for point in (shoulder, elbow, hand):
            cv2.circle(image, tuple(map(int, point)), 12, (30, 30, 30), -1)
        writer.write(image)
    writer.release()
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "screenshots")
    args = parser.parse_args(argv)
    out = args.out
    out.mkdir(parents=True, exist_ok=True)

    app = QApplication.instance() or QApplication([])
    theme.apply_theme(app, 1.0)

    with tempfile.TemporaryDirectory(prefix="rehab-screens-") as folder:
        folder = Path(folder)
        registry = Registry(DataDir(folder / "data"))
        patient = registry.create_patient("Alex", "Example", birth_year=1958, side="right",
                                          body_mass_kg=91.0, upper_arm_m=0.3048,
                                          forearm_m=0.3048, shoulder_m=(-0.12, 0.73))
        code = patient.code
        plan = [  # session, virtual patient, parameters
            (1, "weak", THESIS_SUBJECT.replace(repetitions=2)),
            (1, "weak", THESIS_SUBJECT.replace(repetitions=2)),
            (2, "spastic", THESIS_SUBJECT.replace(repetitions=2)),
            (2, "healthy", THESIS_SUBJECT.replace(repetitions=2)),
            (3, "healthy", THESIS_SUBJECT.replace(repetitions=2, radius_m=0.12,
                                                  duration_s=5.0, assistance_level=0.5)),
            (3, "healthy", THESIS_SUBJECT.replace(repetitions=2)),
        ]
        last = None
        for i, (session, kind, parameters) in enumerate(plan):
            trial = simulate(parameters, patient=kind, seed=i)
            begun = registry.begin_trial(code, parameters, backend="simulator",
                                         session_number=session, patient_kind=kind)
            analysis = save(trial, begun.path, subject_code=code)
            registry.finish_trial(begun.trial_id, trial.status, analysis.metrics.to_dict())
            last = (trial, begun)
        trial, begun = last
        view = TrialView.from_records(trial.records, trial.plan.parameters)
        view.finished = True
        view.source = begun.path

        instructions = InstructionsTab()
        shoot(app, instructions, out / "instructions.png")

        registration = RegistrationTab(registry)
        registration.search_field.setText("exam")
        registration.search()
        registration.results.setCurrentRow(0)
        shoot(app, registration, out / "registration.png")

        parameters = ParametersTab()
        parameters.set_parameters(THESIS_SUBJECT)
        shoot(app, parameters, out / "parameters.png")
        parameters.set_parameters(THESIS_AS_PRINTED)
        parameters.with_camera.setChecked(True)
        shoot(app, parameters, out / "parameters_unreachable.png")

        trajectory = TrajectoryTab()
        trajectory.set_flip(True, True)
        trajectory.show_view(view)
        shoot(app, trajectory, out / "trajectory.png")

        force = ForceTab()
        force.show_view(view)
        shoot(app, force, out / "force.png")

        angles = AnglesTab()
        angles.show_view(view)
        shoot(app, angles, out / "angles.png")

        torques = TorquesTab()
        torques.show_view(view)
        shoot(app, torques, out / "torques.png")
        torques.set_smoothing(True)
        wait(app, lambda: torques._smoothed is not None)
        shoot(app, torques, out / "torques_smoothed.png")

        video = VideoTab()
        shoot(app, video, out / "video_no_camera.png")
        clip = synthetic_video(folder / "clip.avi")
        video.open_camera(str(clip))
        video.resize(*SIZE)
        video.show()
        wait(app, lambda: video.shown_frames() > 10)
        video.camera.start_recording(folder / "recording.mp4")
        wait(app, lambda: video.camera.recorded_frames > 5)
        shoot(app, video, out / "video.png")
        video.close_camera()

        report = ReportTab()
        report.load_registry_trial(registry, begun.trial_id)
        wait(app, lambda: report.content is not None)
        shoot(app, report, out / "report.png")

        progress = ProgressTab(registry)
        progress.set_patient(code)
        wait(app, lambda: progress.progress is not None)
        shoot(app, progress, out / "progress.png")

        replay = ReplayTab(registry)
        replay.set_patient(code)
        replay.open_file(begun.path)
        wait(app, lambda: replay.view is not None)
        replay.slider.setValue(replay.slider.maximum() // 3)
        shoot(app, replay, out / "replay.png")
        force.show_view(replay.view)
        force.set_cursor(replay.view.cursor)
        shoot(app, force, out / "force_replay_cursor.png")

        # The same at the largest text a clinic might choose for a patient far away.
        theme.apply_theme(app, 1.5)
        large = ForceTab()
        large.show_view(view)
        shoot(app, large, out / "force_large_text.png")
        theme.apply_theme(app, 1.0)

        for widget in (instructions, registration, parameters, trajectory, force, angles,
                       torques, video, report, progress, replay, large):
            widget.close()
            widget.deleteLater()
        settle(app, 0.1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
