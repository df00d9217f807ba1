"""Screenshots of the Assessments tab for every task, and each task's report page, after the
whole battery ran headless on the simulator for one fictional patient (issue 31):

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python scripts/assessment_screenshots.py

Writes docs/screenshots/window-assessments-<task>-1366x768.png (the window on a 1366 × 768
laptop below its title bar, the tab showing the task's protocol and the patient's figures)
and docs/assessment-<task>.png (the task's PDF page drawn at 100 dpi). `--patient weak`
runs another virtual patient; `--task strength` (repeatable) runs and shoots only those
tasks (each on the seed the whole battery gives it). The norms are the data folder's in
use (the shipped simulated ones when they exist), so Z-scores appear when they do.
Everything runs in a temporary data folder; nothing touches the clinic's data.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "screenshots"
WIDTH, HEIGHT = 1366, 738


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--patient", default="weak", help="virtual patient (default weak)")
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--task", action="append", default=None,
                        help="a task to run and shoot (repeatable; default the battery)")
    args = parser.parse_args(argv)
    with tempfile.TemporaryDirectory() as folder:
        os.environ["REHAB_DATA_DIR"] = str(Path(folder) / "data")
        os.environ["REHAB_CONFIG_DIR"] = str(Path(folder) / "config")
        from PySide6.QtWidgets import QApplication

        from app.assessments.runner import run_battery
        from app.records.datadir import locate_data_dir
        from app.records.registry import Registry
        from app.reports.assessment_page import page_figure, patient_page
        from core.assessment import TASKS
        from ui import theme
        from ui.main_window import MainWindow

        app = QApplication.instance() or QApplication(sys.argv[:1])
        theme.apply_theme(app, 1.0)
        data_dir = locate_data_dir()
        data_dir.ensure_layout()
        registry = Registry(data_dir)
        code = registry.create_patient(
            "Ada", "Example", birth_year=1961, side="right", body_mass_kg=70.0,
            upper_arm_m=0.30, forearm_m=0.28, shoulder_m=(-0.12, 0.73), sex="female",
            handedness="right").code
        tasks = tuple(args.task or TASKS)
        run_battery(args.patient, seed=args.seed, tasks=tasks, registry=registry, code=code,
                    progress=print)
        win = MainWindow(registry, settings_path=Path(folder) / "config" / "settings.json")
        win.resize(WIDTH, HEIGHT)
        win.show()
        win._on_patient(registry.patient(code))
        win.tabs.setCurrentWidget(win.assessments_tab)
        OUT.mkdir(parents=True, exist_ok=True)
        for task in tasks:
            win.assessments_tab.choose(task)
            win.show_assessment()
            for _ in range(20):
                app.processEvents()
            path = OUT / f"window-assessments-{task}-1366x768.png"
            win.grab().save(str(path))
            print(f"wrote {path.relative_to(ROOT)}")
            page = patient_page(registry, code, task)
            if page is not None:
                out = ROOT / "docs" / f"assessment-{task}.png"
                page_figure(page).savefig(out, dpi=100)
                print(f"wrote {out.relative_to(ROOT)}")
        win.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
