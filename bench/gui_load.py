"""The window under load: repaint rate with every live plot on, the loop's timing while the
window runs a trial, and cold start to a usable window.

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python bench/gui_load.py [--seconds 30]
    QT_QPA_PLATFORM=offscreen .venv/bin/python bench/gui_load.py      # no X at all

1. Live plots: the four live tabs (trajectory, force, joint angles, joint torques) side by
   side in one 1920×1080 window, all visible at once, fed from the real loop process
   (simulator, healthy virtual patient, thesis D) through the same bridge and TrialView the
   console uses; a 16 ms QTimer calls show_view on all four. Prints the achieved repaint
   rate (timer callbacks that redrew all four per second, and paint events of the plots).
2. The loop's lateness p50/p99/p99.9/max, % late and compute p99 during that trial, read
   from the trial file the recorder wrote.
3. Cold start: `rehab gui` in a fresh Python process, from launch to the window's first
   paint, median of 3.
Goals (docs/performance.md): ≥ 50 fps; loop figures as bench/loop_jitter.py's; cold start ≤ 2 s.
Figures only.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import textwrap
import time
from pathlib import Path

import numpy as np

os.environ.setdefault("QT_QPA_PLATFORM", "offscreen" if not os.environ.get("DISPLAY") else "xcb")

from live_feed import feed_live_trial  # bench/, beside this file
from PySide6.QtCore import QEvent, QObject
from PySide6.QtWidgets import QApplication, QGridLayout, QTabWidget, QWidget

from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PERIOD_S
from ui import theme
from ui.tabs import AnglesTab, ForceTab, TorquesTab, TrajectoryTab


class PaintCounter(QObject):
    def __init__(self) -> None:
        super().__init__()
        self.paints = 0

    def eventFilter(self, obj, event) -> bool:
        if event.type() == QEvent.Type.Paint:
            self.paints += 1
        return False


def live_plots(seconds: float, folder: Path, layout: str) -> dict:
    """layout "grid": the four live tabs visible at once; "tabs": as in the console, one
    visible tab at a time (switching every 5 s), the others idle."""
    app = QApplication.instance() or QApplication([])
    theme.apply_theme(app)
    params = THESIS_SUBJECT.replace(repetitions=max(1, round(seconds / 4.0)))
    tabs = [TrajectoryTab(), ForceTab(), AnglesTab(), TorquesTab()]
    counter = PaintCounter()
    if layout == "grid":
        window = QWidget()
        grid = QGridLayout(window)
        for i, tab in enumerate(tabs):
            grid.addWidget(tab, i // 2, i % 2)
    else:
        window = QTabWidget()
        for tab in tabs:
            window.addTab(tab, type(tab).__name__)
    window.resize(1920, 1080)
    for tab in tabs:
        for child in tab.findChildren(QWidget):
            if type(child).__name__ in ("PlotWidget", "GraphicsView", "GraphicsLayoutWidget"):
                child.viewport().installEventFilter(counter)
    window.show()
    painted = {}

    def switch(elapsed_s: float) -> None:
        if layout == "tabs":
            window.setCurrentIndex(int(elapsed_s / 5.0) % len(tabs))

    def show(view) -> None:
        for tab in tabs:
            if tab.isVisible():
                tab.show_view(view)

    path = folder / "gui-load.h5"
    elapsed, frames, view = feed_live_trial(
        app, params, path, show, at_start=lambda: painted.update(at_start=counter.paints),
        meanwhile=switch)
    fps = frames / elapsed
    shown = len(tabs) if layout == "grid" else 1
    paint_rate = (counter.paints - painted["at_start"]) / elapsed / shown
    window.close()
    data = read_trial(path)
    moving = data.channels["phase"] > 0
    lateness = data.channels["lateness"][moving].astype(float)
    compute = data.channels["compute_time"][moving].astype(float)
    return {
        "fps": fps, "paints_per_plot": paint_rate, "samples": data.n_samples,
        "view_samples": view.n,
        "p50_ms": 1e3 * np.percentile(lateness, 50), "p99_ms": 1e3 * np.percentile(lateness, 99),
        "p999_ms": 1e3 * np.percentile(lateness, 99.9), "max_ms": 1e3 * lateness.max(),
        "late_pct": 100 * np.mean(lateness > PERIOD_S),
        "compute_p99_us": 1e6 * np.percentile(compute, 99), "status": data.status,
    }


CHILD = textwrap.dedent("""
    import sys, time
    from PySide6.QtCore import QObject, QEvent, QTimer
    from PySide6.QtWidgets import QApplication, QMainWindow

    class FirstPaint(QObject):
        def eventFilter(self, obj, event):
            if event.type() == QEvent.Type.Paint and isinstance(obj, QMainWindow):
                print(f"painted {time.time()!r}", flush=True)
                QTimer.singleShot(0, obj.close)
                obj.removeEventFilter(self)
            return False

    def main():
        original = QApplication.exec
        def exec_(*args):
            app = QApplication.instance()
            for widget in app.topLevelWidgets():
                if isinstance(widget, QMainWindow):
                    widget.installEventFilter(watcher)
            return original()
        watcher = FirstPaint()
        QApplication.exec = staticmethod(exec_)
        from ui.launcher import main as rehab
        return rehab(["gui"])

    if __name__ == "__main__":
        sys.exit(main())
""")


def cold_start(folder: Path, runs: int = 3) -> list[float]:
    script = folder / "cold_start.py"
    script.write_text(CHILD)
    env = dict(os.environ, REHAB_DATA_DIR=str(folder / "data"),
               REHAB_CONFIG_DIR=str(folder / "config"))
    times = []
    for _ in range(runs):
        launched = time.time()
        out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                             env=env, timeout=60, cwd=Path(__file__).resolve().parents[1])
        painted = [line for line in out.stdout.splitlines() if line.startswith("painted")]
        if painted:
            times.append(float(painted[0].split()[1]) - launched)
    return times


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as folder:
        folder = Path(folder)
        runs = {layout: live_plots(args.seconds, folder / layout, layout)
                for layout in ("tabs", "grid")}
        starts = cold_start(folder)
    print(f"display: {os.environ.get('QT_QPA_PLATFORM')} {os.environ.get('DISPLAY', '')}")
    labels = {"tabs": "as in the console: the visible live tab",
              "grid": "stress: all four live tabs visible at once"}
    for layout, live in runs.items():
        print(f"{labels[layout]} (16 ms timer, {live['view_samples']} samples at the end): "
              f"{live['fps']:.1f} repaints/s, {live['paints_per_plot']:.1f} paints per "
              "shown plot per s")
        print(f"  loop beside it ({live['samples']} ticks, {live['status']}): lateness "
              f"p50 {live['p50_ms']:.3f} ms, p99 {live['p99_ms']:.3f} ms, p99.9 "
              f"{live['p999_ms']:.3f} ms, max {live['max_ms']:.3f} ms, "
              f"late {live['late_pct']:.3f} %, compute p99 {live['compute_p99_us']:.0f} µs")
    if starts:
        print(f"cold start to the window's first paint: median {statistics.median(starts):.2f} s"
              f" (runs: {', '.join(f'{t:.2f}' for t in starts)})")
    else:
        print("cold start: the window did not paint (no display?)")


if __name__ == "__main__":
    main()
