"""The tabs about finished trials: replay (open a file, scrub), the report (plain lines,
print, PDF) and progress (every trial of a patient, grouped by exercise)."""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
import pytest
from pypdf import PdfReader
from PySide6.QtCore import Qt
from PySide6.QtPrintSupport import QPrinter

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.trials.headless import save, simulate
from core.trial import THESIS_SUBJECT
from tests.ui.shown import shown
from ui import theme
from ui.tabs import ProgressTab, ReplayTab, ReportTab
from ui.views.trialview import TrialView

EASY = THESIS_SUBJECT.replace(repetitions=1)
HARD = THESIS_SUBJECT.replace(repetitions=1, radius_m=0.12, duration_s=5.0)


@pytest.fixture(scope="module")
def history(tmp_path_factory):
    """A registry with one patient and three saved trials over two sessions, two at the
    thesis's D and one at a larger, slower D."""
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Lovelace", side="right").code
    trials = []
    for session, parameters, patient in ((1, EASY, "weak"), (1, HARD, "healthy"),
                                         (2, EASY, "healthy")):
        trial = simulate(parameters, patient=patient, seed=session)
        begun = registry.begin_trial(code, parameters, backend="simulator",
                                     session_number=session, patient_kind=patient)
        analysis = save(trial, begun.path, subject_code=code)
        registry.finish_trial(begun.trial_id, trial.status, analysis.metrics.to_dict())
        trials.append((begun, analysis))
    return registry, code, trials


@pytest.fixture(autouse=True)
def themed(qapp):
    theme.apply_theme(qapp)


def test_replay_loads_a_trial_and_the_slider_moves_the_cursor(qtbot, history):
    registry, code, trials = history
    tab = shown(qtbot, ReplayTab(registry))
    tab.set_patient(code)
    assert tab.trials.count() == 3
    assert tab.trials.item(0).text().startswith("Session 2, trial 1")

    tab.trials.setCurrentRow(2)  # the oldest: session 1, trial 1
    with qtbot.waitSignal(tab.view_loaded, timeout=5000) as loaded:
        qtbot.mouseClick(tab.open_selected, Qt.MouseButton.LeftButton)
    view = loaded.args[0]
    assert isinstance(view, TrialView)
    assert view.finished
    assert view.source == trials[0][0].path
    assert view.parameters == EASY
    assert view.rmse_xy_m[0] == pytest.approx(trials[0][1].metrics.rmse_x_m, rel=1e-9)
    assert tab.slider.isEnabled()
    assert tab.slider.maximum() == view.n - 1

    with qtbot.waitSignal(tab.cursor_moved) as moved:
        tab.slider.setValue(1000)
    assert moved.args[0] == pytest.approx(view.time[1000])
    assert view.cursor == pytest.approx(view.time[1000])
    assert tab.time_label.text() == f"{view.time[1000] - view.time[0]:.1f} s of " \
                                    f"{view.duration_s:.1f} s"
    x_cm = view.column("position")[0, 1000] * 100
    assert f"x {x_cm:.1f} cm".replace("-", "−") in tab.moment["position"].text()
    assert tab.moment["phase"].text() == "exercise"

    tab.set_cursor(2.0)  # from elsewhere: no echo
    assert tab.slider.value() == view.index_at(2.0)


def test_replay_marks_the_trial_it_shows_in_its_list(qtbot, history, tmp_path):
    """The list kept its first row (the newest trial) marked over a trial opened with Open
    file… (issue 27 #14: which trial is shown must be plain): it marks the trial shown,
    and nothing for a file not in the list."""
    registry, code, trials = history
    tab = shown(qtbot, ReplayTab(registry))
    tab.set_patient(code)
    assert tab.trials.currentRow() == 0  # the newest, before anything is shown
    with qtbot.waitSignal(tab.view_loaded, timeout=5000):
        tab.open_file(trials[0][0].path)  # session 1, trial 1: the list's last row
    assert tab.trials.currentRow() == 2
    assert [item.text() for item in tab.trials.selectedItems()] == [tab.trials.item(2).text()]
    assert tab.trials.item(2).text().startswith("Session 1, trial 1")
    elsewhere = tmp_path / "copy.h5"
    elsewhere.write_bytes(trials[1][0].path.read_bytes())
    with qtbot.waitSignal(tab.view_loaded, timeout=5000):
        tab.open_file(elsewhere)
    assert tab.trials.currentRow() == -1
    assert tab.trials.selectedItems() == []


def test_replay_plays_forward(qtbot, history):
    registry, _, trials = history
    tab = shown(qtbot, ReplayTab(registry))
    with qtbot.waitSignal(tab.view_loaded, timeout=5000):
        tab.open_file(trials[2][0].path)
    tab.speed.setCurrentIndex(tab.speed.findData(4.0))
    times = []
    tab.cursor_moved.connect(times.append)
    tab.play.click()
    qtbot.waitUntil(lambda: len(times) >= 3, timeout=3000)
    tab.play.click()
    assert np.all(np.diff(times) > 0)
    assert tab.play.text() == "Play"


def test_replay_of_a_damaged_file_says_why(qtbot, tmp_path):
    bad = tmp_path / "broken.h5"
    bad.write_bytes(b"not a trial")
    tab = shown(qtbot, ReplayTab())
    with qtbot.waitSignal(tab.load_failed, timeout=5000) as failed:
        tab.open_file(bad)
    assert "not an HDF5 file" in failed.args[0]
    assert "not an HDF5 file" in tab.info.text()


def test_report_shows_the_plain_lines_and_prints(qtbot, history, tmp_path):
    registry, _, trials = history
    begun, analysis = trials[2]
    tab = shown(qtbot, ReportTab())
    assert not tab.pdf_button.isEnabled()
    with qtbot.waitSignal(tab.report_ready, timeout=5000) as ready:
        tab.load_registry_trial(registry, begun.trial_id)
    content = ready.args[0]
    lines = tab.lines()
    percent = round(analysis.metrics.directional_performance_pct)
    assert (f"You pushed in the right direction {percent} % of the time."
            in lines)
    shoulder = round(math.degrees(analysis.metrics.shoulder_rom_rad))
    assert f"Your shoulder moved through {shoulder}°." in lines
    assert all(line.text in lines for line in content.plain)
    # Compared with the previous session's trial at the same exercise.
    assert any("previous" in text.lower() for text in lines)
    assert tab.pdf_button.isEnabled()

    printed = tmp_path / "printed.pdf"
    printer = QPrinter(QPrinter.PrinterMode.HighResolution)
    printer.setOutputFormat(QPrinter.OutputFormat.PdfFormat)
    printer.setOutputFileName(str(printed))
    tab.print_to(printer)
    text = " ".join(" ".join(page.extract_text().split()) for page in PdfReader(printed).pages)
    assert "right direction" in text
    assert "Position error" in text

    saved = tmp_path / "report.pdf"
    with qtbot.waitSignal(tab.pdf_saved, timeout=20000) as done:
        tab.save_pdf(saved)
    assert done.args[0] == saved
    assert saved.read_bytes().startswith(b"%PDF")


def test_report_follows_a_replayed_view(qtbot, history):
    _, _, trials = history
    tab = shown(qtbot, ReportTab())
    live = TrialView(EASY)
    tab.show_view(live)
    assert "once the trial is saved" in tab.message.text()
    view = TrialView(EASY)
    view.source = trials[0][0].path
    with qtbot.waitSignal(tab.report_ready, timeout=5000) as ready:
        tab.show_view(view)
    assert ready.args[0].source == trials[0][0].path


def test_progress_lists_every_trial_grouped_by_exercise(qtbot, history):
    registry, code, trials = history
    tab = shown(qtbot, ProgressTab(registry))
    with qtbot.waitSignal(tab.progress_loaded, timeout=5000):
        tab.set_patient(code)
    assert tab.table.rowCount() == 3
    heads = [tab.table.horizontalHeaderItem(c).text() for c in range(tab.table.columnCount())]
    column = heads.index("Position error, x (RMSE) (mm)")
    for row, (_, analysis) in enumerate(trials):
        assert tab.table.item(row, 0).text() == ("1", "1", "2")[row]
        # mm: one place, as the report writes it
        assert tab.table.item(row, column).text() == f"{analysis.metrics.rmse_x_m * 1000:.1f}"
    assert "r 12.0 cm" in tab.table.item(1, heads.index("Exercise")).text()

    # two exercises (two sizes), one series each; the latest trial's shown first
    assert tab.exercise_choice.count() == 2
    assert "r 10.0 cm" in tab.exercise_choice.currentText()
    tab.metric_choice.setCurrentIndex(tab.metric_choice.findData("rmse_x_m"))
    (curve,) = [c for c in tab.plot.getPlotItem().listDataItems()
                if isinstance(c, pg.PlotDataItem)]
    x, y = curve.getOriginalDataset()
    np.testing.assert_array_equal(x, [1, 2])
    np.testing.assert_allclose(y, [trials[0][1].metrics.rmse_x_m * 1000,
                                   trials[2][1].metrics.rmse_x_m * 1000])
    tab.exercise_choice.setCurrentIndex(tab.exercise_choice.findText(
        next(tab.exercise_choice.itemText(i) for i in range(2)
             if "r 12.0 cm" in tab.exercise_choice.itemText(i))))
    (curve,) = [c for c in tab.plot.getPlotItem().listDataItems()
                if isinstance(c, pg.PlotDataItem)]
    np.testing.assert_allclose(curve.getOriginalDataset()[1],
                               [trials[1][1].metrics.rmse_x_m * 1000])


def test_replay_s_list_names_games_and_assessments_whole_at_a_large_font(qtbot, history):
    """Found driving the window (brief hO): the list said only numbers, time and status,
    so a game's round or an assessment task read as any trial of its shape. Each row now
    names it as Progress's series do, on a second line wrapped at a large font, never cut
    with "…" (an assessment's name is the longest)."""
    import datetime

    from PySide6.QtCore import QRect
    from PySide6.QtGui import QFontMetrics
    from PySide6.QtWidgets import QApplication

    from app.records.registry import Trial
    from core.trial import TrialParameters

    registry, code, _ = history
    started = datetime.datetime(2026, 12, 5, 9, 30, tzinfo=datetime.UTC)
    kinds = ({"game": "reach", "shape": "reach"},
             {"assessment": "circle", "shape": "circle", "radius_m": 0.07,
              "assist": "transparent"})
    trials = [Trial(k, code, 1, started.date(), k, TrialParameters().replace(**kind)
                    .to_dict(), "x.h5", {}, "complete", started, None, "simulator", None)
              for k, kind in enumerate(kinds, 1)]
    theme.apply_theme(QApplication.instance(), 1.5)
    try:
        tab = shown(qtbot, ReplayTab(registry))
        tab.resize(1366, 600)
        tab.set_patient(code, trials)
        QApplication.processEvents()
        texts = [tab.trials.item(r).text() for r in range(tab.trials.count())]
        assert texts[0].split("\n")[1].startswith("Assessment: Circle drawing · ")
        assert texts[1].split("\n")[1].startswith("Reaching game · ")
        metrics = QFontMetrics(tab.trials.font())
        for row, text in enumerate(texts):
            rect = tab.trials.visualItemRect(tab.trials.item(row))
            needed = metrics.boundingRect(QRect(0, 0, rect.width() - 8, 10_000),
                                          int(Qt.TextFlag.TextWordWrap), text)
            assert rect.height() >= needed.height(), (text, rect, needed)
    finally:
        theme.apply_theme(QApplication.instance(), 1.0)
