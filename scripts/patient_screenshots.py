"""Screenshots of the patient's screen, full screen on a 1920 × 1080 monitor, from trials run
on the simulator (virtual patients, the trial files the console writes) shown at chosen
moments as the live screen shows them:

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python scripts/patient_screenshots.py

Writes docs/screenshots/patient-<what>.png: the D at Go, the D in its second lap (the
first lap's path faint, "Done!" with its quality), the path game, the reaching game, a neglect
layout (the reaching game turned toward the patient's left, the cue on that side), and a
session plan's rest. Everything runs in a temporary folder; nothing touches the clinic's
data. The plan's rest is the state the plan's runner gives during a rest
(app.plans.runner.PlanState), drawn over the next block's exercise.
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "screenshots"
SIZE = (1920, 1080)


def main() -> int:
    from PySide6.QtWidgets import QApplication

    from app.plans.runner import PlanState
    from app.trials.headless import simulate_to_file
    from app.trials.reader import read_trial
    from core.trial import THESIS_SUBJECT
    from device.recording.record import RECORD_DTYPE
    from ui.patient.window import PatientWindow
    from ui.views.trialview import VIEW_CHANNELS, TrialView

    app = QApplication.instance() or QApplication(sys.argv[:1])
    reach = THESIS_SUBJECT.replace(shape="targets", game="reach", centre_m=(-0.2, 0.35),
                                   radius_m=0.08, n_targets=6, duration_s=9.0, repetitions=1,
                                   time_allowed_s=1.2, n_distractors=2, assist="as-needed")
    trials = {
        "d": (THESIS_SUBJECT.replace(repetitions=3, duration_s=4.0, assist="as-needed"),
              "weak"),
        "path-game": (THESIS_SUBJECT.replace(game="path", repetitions=2, duration_s=4.0,
                                             channel_half_width_m=0.015,
                                             assist="transparent"), "weak"),
        "reach-game": (reach, "healthy"),
        "neglect": (reach.replace(n_targets=5, neglect_side="left", n_distractors=0,
                                  duration_s=7.5), "healthy"),
    }
    OUT.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as folder:
        data = {}
        for name, (params, patient) in trials.items():
            path = Path(folder) / f"{name}.h5"
            simulate_to_file(params, path, patient=patient, seed=7)
            data[name] = read_trial(path)
        window = PatientWindow()
        window.resize(*SIZE)
        window.show()

        def live_until(trial, t_s: float) -> TrialView:
            """A live view fed the file's samples up to t_s in 16 ms batches, as the
            window's repaint feeds it (the game's scorer sees each once, in order)."""
            view = TrialView(trial.parameters)
            rows = _rows(trial, VIEW_CHANNELS, RECORD_DTYPE)
            rows = rows[rows["phase"] > 0]
            end = int((rows["time"] <= t_s).sum())
            for start in range(0, end, 8):
                view.append(rows[start:min(start + 8, end)])
                window.show_view(view)
            return view

        def shoot(name: str) -> None:
            app.processEvents()
            path = OUT / f"patient-{name}.png"
            window.grab().save(str(path))
            print(path, f"{window.width()}x{window.height()}", window.frame.message,
                  window.painted.get("top"))

        live_until(data["d"], 0.3)
        shoot("d-go")
        live_until(data["d"], 4.0 + 0.6)
        shoot("d-round-2")
        live_until(data["path-game"], 5.2)
        shoot("path-game")
        layout_times = [t.onset_s for t in _layout(data["reach-game"]).targets]
        live_until(data["reach-game"], layout_times[2] + 0.25)
        shoot("reach-game")
        live_until(data["neglect"], [t.onset_s for t in _layout(data["neglect"]).targets][3]
                   + 0.2)
        shoot("neglect")
        window.show_view(live_until(data["d"], 0.0))
        window.show_plan(PlanState("resting", 1, 3, "D shape", 1, 1, 3, 0, 15, 45, 43.4,
                                   150.0, "", "", done_share=1 / 3, lap_share=1 / 9,
                                   next_trial=reach.replace(n_distractors=0), next_rounds=3))
        shoot("rest")
        window.close()
    return 0


def _rows(trial, names, record_dtype):
    import numpy as np

    rows = np.zeros(trial.n_samples, dtype=[(c, record_dtype.fields[c][0]) for c in names])
    for name in names:
        rows[name] = trial.channels[name]
    return rows


def _layout(trial):
    from core.games import game_layout

    return game_layout(trial.parameters)


if __name__ == "__main__":
    sys.exit(main())
