"""The patient's screen beside a running trial: its frame rate, what a frame costs, and the
loop's lateness with and without it.

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python bench/patient_screen.py [--seconds 30]
    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/patient_screen.py      # no X at all

Two live trials on the simulator (healthy virtual patient, the thesis's D, the real loop and
recorder processes behind the console's DeviceBridge), one after the other, each fed by a
16 ms QTimer into a TrialView as the console's window feeds its live view:
1. without the patient's screen: the timer only takes the records and appends them;
2. with the patient's window (ui.patient.window.PatientWindow) full size (1920 × 1080),
   shown: the timer also calls show_view, which repaints it when the newest sample changed.
   With `--game` the trial is the path game (channel, ball, score: the scorer fed live).
Printed: the patient window's frames per second = paint events it received per second of
the trial (the 16 ms timer caps it at 62.5; the goal is ≥ 60), what one paint costs
(paintEvent's own time, p50/p99/max: the headroom under the cap), and for each run the
loop's lateness p50/p99/p99.9/max and % late from the trial file the recorder wrote.
Figures only.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen" if not os.environ.get("DISPLAY") else "xcb")

from live_feed import feed_live_trial  # bench/, beside this file
from PySide6.QtWidgets import QApplication

from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PERIOD_S
from ui import theme
from ui.patient.window import PatientWindow


class TimedPatientWindow(PatientWindow):
    """The patient's window with each paint timed (the bench's only addition)."""

    def __init__(self) -> None:
        super().__init__()
        self.paint_s: list[float] = []

    def paintEvent(self, event) -> None:
        started = time.perf_counter()
        super().paintEvent(event)
        self.paint_s.append(time.perf_counter() - started)


def run(app: QApplication, seconds: float, folder: Path, with_screen: bool, game: bool) -> dict:
    params = THESIS_SUBJECT.replace(repetitions=max(1, round(seconds / 4.0)),
                                    assist="as-needed", game="path" if game else "")
    window = None
    if with_screen:
        window = TimedPatientWindow()
        window.resize(1920, 1080)
        window.show()
    painted = {}

    def show(view) -> None:
        if window is not None:
            window.show_view(view)

    path = folder / ("with.h5" if with_screen else "without.h5")
    elapsed, ticks, _ = feed_live_trial(
        app, params, path, show,
        at_start=lambda: painted.update(at_start=window.paints if window is not None else 0))
    paints0 = painted["at_start"]
    out = {"timer_hz": ticks / elapsed}
    if window is not None:
        out["fps"] = (window.paints - paints0) / elapsed
        paint_ms = 1e3 * np.array(window.paint_s)
        out.update(paint_p50_ms=np.percentile(paint_ms, 50),
                   paint_p99_ms=np.percentile(paint_ms, 99), paint_max_ms=paint_ms.max())
        window.close()
    data = read_trial(path)
    moving = data.channels["phase"] > 0
    lateness = data.channels["lateness"][moving].astype(float)
    ended = [f"{e.get('kind')}: {e.get('message')}" for e in data.events
             if e.get("kind") in ("fault", "recording", "stop")]
    out.update(samples=int(moving.sum()), status=data.status, ended="; ".join(ended),
               p50_ms=1e3 * np.percentile(lateness, 50), p99_ms=1e3 * np.percentile(lateness, 99),
               p999_ms=1e3 * np.percentile(lateness, 99.9), max_ms=1e3 * lateness.max(),
               late_pct=100 * np.mean(lateness > PERIOD_S))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--game", action="store_true", help="the path game instead of the D")
    args = parser.parse_args()
    app = QApplication.instance() or QApplication([])
    theme.apply_theme(app)
    with tempfile.TemporaryDirectory() as folder:
        runs = {name: run(app, args.seconds, Path(folder) / name, name == "with", args.game)
                for name in ("without", "with")}
    print(f"display: {os.environ.get('QT_QPA_PLATFORM')} {os.environ.get('DISPLAY', '')}; "
          f"{'path game' if args.game else 'the D'}, {args.seconds:g} s trials")
    shown = runs["with"]
    print(f"patient's screen 1920 × 1080: {shown['fps']:.1f} frames/s (16 ms timer: "
          f"{shown['timer_hz']:.1f} calls/s, cap 62.5); a paint p50 "
          f"{shown['paint_p50_ms']:.2f} ms, p99 {shown['paint_p99_ms']:.2f} ms, max "
          f"{shown['paint_max_ms']:.2f} ms")
    for name, live in runs.items():
        print(f"loop {name} the patient's screen ({live['samples']} ticks, {live['status']}): "
              f"lateness p50 {live['p50_ms']:.3f} ms, p99 {live['p99_ms']:.3f} ms, p99.9 "
              f"{live['p999_ms']:.3f} ms, max {live['max_ms']:.3f} ms, "
              f"late {live['late_pct']:.3f} %")
        if live["status"] != "complete":
            print(f"  it ended {live['status']}: {live['ended']}")


if __name__ == "__main__":
    main()
