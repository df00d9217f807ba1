"""Screenshots and report pages of the clinical record (issue 31): the Progress tab's
clinical scales (a robot figure against the Fugl-Meyer over a patient's sessions, and
across a study), the Registration tab's clinical record, and the session report and the
progress PDF's scales page as PNG (pdftoppm):

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python scripts/clinical_screenshots.py

Every trial is simulated and finished as the console does (app.trials.headless,
app.trials.finalize) in a temporary data folder with fictional patients: three of them
over four sessions each, the virtual patient stronger session by session (passive, weak,
weak with less impairment, healthy) and the Fugl-Meyer rising with it; one trial marked
invalid. Writes docs/screenshots/window-progress-scales-1366x768.png,
window-registration-clinical-1366x768.png, report-session-1.png (and -2 when the report
has a second page) and report-progress-scales.png.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "docs" / "screenshots"
COURSE = (("passive", 12), ("weak", 24), ("weak", 31), ("healthy", 45))
"""Each session's virtual patient and the Fugl-Meyer UE motor the therapist scored."""


def course(registry, code: str, offset: int, seed: int) -> None:
    from app.trials.finalize import finalize_trial
    from app.trials.headless import simulate_to_file
    from core.trial import THESIS_SUBJECT

    parameters = THESIS_SUBJECT.replace(repetitions=1, assist="transparent")
    for number, (kind, fugl_meyer) in enumerate(COURSE, start=1):
        registry.open_session(code, therapist="K. Lee", location="room 2")
        for k in range(2):
            begun = registry.begin_trial(code, parameters, backend="simulator",
                                         session_number=number, patient_kind=kind)
            simulate_to_file(parameters, begun.path, subject_code=code, patient=kind,
                             seed=seed + 10 * number + k)
            finalize_trial(registry, begun.trial_id)
        registry.record_scale(code, number, "fugl_meyer", total=max(0, fugl_meyer + offset),
                              rater="K. Lee")
        registry.record_scale(code, number, "pain", total=max(0, 4 - number + offset // 4),
                              rater="K. Lee")


def _assessment(registry, code: str, number: int) -> None:
    """A visually guided reaching task in the session, as the battery runs it."""
    from app.trials.finalize import finalize_trial
    from app.trials.headless import simulate_to_file
    from core.assessment.protocol import protocol
    from core.trial import THESIS_SUBJECT

    parameters = protocol("reaching").parameters(THESIS_SUBJECT, 0)
    begun = registry.begin_trial(code, parameters, backend="simulator",
                                 session_number=number, patient_kind="weak")
    simulate_to_file(parameters, begun.path, subject_code=code, patient="weak", seed=7)
    finalize_trial(registry, begun.trial_id)


def main() -> int:
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication(sys.argv[:1])
    with tempfile.TemporaryDirectory() as folder:
        os.environ["REHAB_DATA_DIR"] = str(Path(folder) / "data")
        os.environ["REHAB_CONFIG_DIR"] = str(Path(folder) / "config")
        shoot(app, Path(folder))
    return 0


def shoot(app, folder: Path) -> None:
    from app.records.datadir import locate_data_dir
    from app.records.registry import Registry
    from app.reports.progress import progress
    from app.reports.progress_pdf import write_progress_pdf
    from app.reports.scales_progress import report_series
    from app.reports.session_report import write_session_report
    from ui import theme
    from ui.tabs import ProgressTab
    from ui.tabs.registration import RegistrationTab

    theme.apply_theme(app, 1.0)
    data_dir = locate_data_dir()
    data_dir.ensure_layout()
    registry = Registry(data_dir)
    codes = []
    for i, (first, offset) in enumerate((("Ada", 0), ("Bo", -6), ("Cy", 5))):
        patient = registry.create_patient(first, "Example", birth_year=1958 + 4 * i,
                                          side="right", sex="female" if i % 2 else "male",
                                          handedness="right", upper_arm_m=0.31,
                                          forearm_m=0.28)
        course(registry, patient.code, offset, seed=100 * i)
        codes.append(patient.code)
    code = codes[0]
    _assessment(registry, code, 2)
    trials = registry.trials(code, 2)
    registry.mark_trial(trials[1].id, valid=False, reason="let go of the handle mid-lap",
                        by="K. Lee")
    registry.add_note(code, 2, "shoulder pain before the start, eased after the rest",
                      author="K. Lee")
    registry.add_note(code, 2, "coughed during the lap", author="K. Lee",
                      trial_id=trials[1].id)

    tab = ProgressTab(registry)
    tab.resize(1366, 738)
    tab.show()
    tab.include_invalid.setChecked(False)
    tab.set_patient(code)
    _wait(app, lambda: tab.progress is not None and tab.scales.view is not None)
    tab.scales_button.setChecked(True)
    figure = tab.scales.figure_choice.findData("rmse_x_m")
    if figure >= 0:
        tab.scales.figure_choice.setCurrentIndex(figure)
    _settle(app, tab.scales, lambda view: view.series.figure_key == "rmse_x_m")
    tab.grab().save(str(OUT / "window-progress-scales-1366x768.png"))
    tab.scales.study.setChecked(True)
    _settle(app, tab.scales, lambda view: view.caption.startswith("Study"))
    tab.grab().save(str(OUT / "window-progress-scales-study-1366x768.png"))

    registration = RegistrationTab(registry)
    registration.resize(1366, 738)
    registration.show()
    registration.choose(registry.patient(code))
    _wait(app, lambda: registration.selected_patient() is not None)  # read on the job thread
    registration.clinical.by.setText("K. Lee")
    registration.clinical.scores.setText("A=20 B=5 C=6 D=3")
    registration.clinical.record_scale()
    _wait(app, lambda: not registration.clinical.saving())  # kept on the job thread
    registration.bring_into_view(registration.clinical)
    _wait(app, lambda: True)
    registration.grab().save(str(OUT / "window-registration-clinical-1366x768.png"))

    reports = data_dir.ensure("reports", code)
    from app.norms.in_use import norms_in_use

    session_pdf = write_session_report(registry, code, 2, reports / "session.pdf",
                                       norms=norms_in_use(data_dir))
    _pages(session_pdf, OUT / "report-session")
    prog = progress(registry, code)
    progress_pdf = write_progress_pdf(prog, reports / "progress.pdf",
                                      scales=registry.session_scales(code),
                                      series=report_series(registry, prog))
    pages = len(_pdf_pages(progress_pdf))
    _pages(progress_pdf, OUT / "report-progress-scales", first=pages, last=pages)


def _pdf_pages(path: Path) -> list:
    from pypdf import PdfReader

    return list(PdfReader(path).pages)


def _pages(pdf: Path, stem: Path, first: int | None = None, last: int | None = None) -> None:
    """The PDF's pages as PNG (pdftoppm, 80 dpi): stem-1.png, stem-2.png, …"""
    if shutil.which("pdftoppm") is None:
        raise SystemExit("pdftoppm is needed (poppler-utils)")
    args = ["pdftoppm", "-png", "-r", "80"]
    if first is not None:
        args += ["-f", str(first), "-l", str(last), "-singlefile"]
    subprocess.run([*args, str(pdf), str(stem)], check=True)


def _wait(app, condition, timeout_s: float = 60.0) -> None:
    import time

    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        app.processEvents()
        if condition():
            for _ in range(20):
                app.processEvents()
                time.sleep(0.02)
            return
        time.sleep(0.02)
    raise SystemExit("the window did not show what was asked in time")


def _settle(app, panel, condition) -> None:
    _wait(app, lambda: panel.view is not None and panel.view.series is not None
          and condition(panel.view))


if __name__ == "__main__":
    sys.path.insert(0, str(ROOT))
    raise SystemExit(main())
