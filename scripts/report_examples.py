"""The report's page for the patient in each assistance mode and for a trial cut short by the
emergency stop, and Progress with a staircase of the robot's help (the tab and its PDF),
drawn from simulated trials, as PNGs for the docs and for review.

    QT_QPA_PLATFORM=offscreen .venv/bin/python scripts/report_examples.py [--out docs]

Writes report-example.png (as needed), report-example-thesis.png,
report-example-cut-short.png, progress-example.png (the Progress tab) and
progress-example-pdf.png (the PDF's page of that exercise). Everything runs in a temporary
data folder: one fictional patient, the simulated trials the report tests make
(tests/app/reports/made.py), registered and finished as the window does. The report's
pages are the figures the PDF is made of (app.reports.pdf.report_pages), drawn to PNG.
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

import matplotlib  # noqa: E402

from app.records.datadir import DataDir  # noqa: E402
from app.records.registry import Registry  # noqa: E402
from app.reports.build import content_for_registry_trial  # noqa: E402
from app.reports.pdf import report_pages  # noqa: E402
from app.reports.pdf_sheet import RC  # noqa: E402
from app.reports.progress import progress  # noqa: E402
from app.reports.progress_pdf import progress_pages  # noqa: E402
from core.trial import THESIS_SUBJECT  # noqa: E402
from tests.app.reports.made import cut, register, staircase_course  # noqa: E402

AS_NEEDED = THESIS_SUBJECT.replace(repetitions=3, assist="as-needed")
THESIS = THESIS_SUBJECT.replace(repetitions=3)


def save_page(page, path: Path, dpi: float) -> None:
    with matplotlib.rc_context(RC):
        page.savefig(path, dpi=dpi)
    say(path)


def say(path: Path) -> None:
    print(f"wrote {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}")


def reports(registry: Registry, code: str, out: Path, dpi: float) -> None:
    register(registry, code, AS_NEEDED, session=1, seed=1)
    register(registry, code, AS_NEEDED, session=2, seed=2, minutes=7 * 24 * 60)
    as_needed = register(registry, code, AS_NEEDED, session=2, seed=3,
                         minutes=7 * 24 * 60 + 5)
    cut_short = register(registry, code, AS_NEEDED, session=2, seed=4,
                         minutes=7 * 24 * 60 + 10,
                         edit=lambda trial: cut(trial, 0.35, "faulted"))
    register(registry, code, THESIS, session=1, seed=5, minutes=10)
    thesis = register(registry, code, THESIS, session=2, seed=6, minutes=7 * 24 * 60 + 15)
    for name, trial_id in (("report-example", as_needed),
                           ("report-example-thesis", thesis),
                           ("report-example-cut-short", cut_short)):
        pages = report_pages(content_for_registry_trial(registry, trial_id))
        save_page(pages[0], out / f"{name}.png", dpi)


def progress_examples(registry: Registry, code: str, out: Path, dpi: float) -> None:
    from PySide6.QtWidgets import QApplication

    from ui import theme
    from ui.tabs import ProgressTab

    staircase_course(registry, code, THESIS_SUBJECT.replace(repetitions=2))
    result = progress(registry, code)
    save_page(progress_pages(result)[0], out / "progress-example-pdf.png", dpi)
    app = QApplication.instance() or QApplication([])
    theme.apply_theme(app, 1.0)
    tab = ProgressTab(registry)
    tab.resize(1280, 800)
    tab.show()
    tab.set_patient(code)
    deadline = time.monotonic() + 30.0
    while tab.progress is None:
        if time.monotonic() > deadline:
            raise TimeoutError("the Progress tab did not load")
        app.processEvents()
        time.sleep(0.01)
    tab.exercise_choice.setCurrentIndex(0)  # the as-needed exercise, its staircase
    for _ in range(20):
        app.processEvents()
        time.sleep(0.01)
    tab.grab().save(str(out / "progress-example.png"))
    say(out / "progress-example.png")


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs")
    parser.add_argument("--dpi", type=float, default=80.0)
    args = parser.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="rehab-report-examples-") as folder:
        registry = Registry(DataDir(Path(folder) / "data"))
        reports(registry, registry.create_patient("Alex", "Example", side="right").code,
                args.out, args.dpi)
        progress_examples(registry, registry.create_patient("Sam", "Example").code,
                          args.out, args.dpi)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
