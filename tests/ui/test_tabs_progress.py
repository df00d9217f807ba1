"""Issue 27 #7 on the screen: the Progress tab shows one exercise's series at a time (the
assistance mode and the exercise), the mode's own success figure first, the robot's help
beneath as the staircase it ran, the pace where it changed, the key on a line above the
plots (never over the data), and saves the same as a PDF."""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
import pytest
from pypdf import PdfReader

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.progress_figure import progress_figure
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import many_trials, staircase_course
from tests.ui.shown import shown
from ui import theme
from ui.tabs import ProgressTab
from ui.tabs.progress import CUT_SHORT_PX


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Example", side="right").code
    staircase_course(registry, code, THESIS_SUBJECT.replace(repetitions=1))
    return registry, code


@pytest.fixture
def tab(qtbot, qapp, course):
    theme.apply_theme(qapp)
    registry, code = course
    tab = ProgressTab(registry)
    shown(qtbot, tab)
    with qtbot.waitSignal(tab.progress_loaded, timeout=10000):
        tab.set_patient(code)
    return tab


def _curves(plot) -> list:
    return [item for item in plot.getPlotItem().items if isinstance(item, pg.PlotDataItem)]


def test_one_exercise_at_a_time_with_its_own_success_figure_first(tab):
    # opens on the latest trial's exercise: the thesis mode, its figure the push's direction
    assert tab.exercise_choice.count() == 2
    assert tab.exercise_choice.currentText().startswith("Thesis mode · D shape")
    assert tab.metric_choice.currentData() == "directional_performance_pct"
    assert tab.metric_choice.findData("led_pct") == -1
    tab.exercise_choice.setCurrentIndex(0)
    assert tab.exercise_choice.currentText() == "As needed · D shape, r 10.0 cm · SMC (5)"
    assert tab.metric_choice.currentData() == "led_pct"
    (line,) = _curves(tab.plot)
    x, y = line.getOriginalDataset()
    # five trials, one series; the line joins the four that ran the whole exercise, the
    # e-stopped fifth is a hollow mark off it
    np.testing.assert_array_equal(x, [1, 2, 3, 4])
    led = tab.progress.values["led_pct"][tab.progress.members(0)]
    np.testing.assert_allclose(y, led[:4])
    (hollow,) = [item for item in tab.plot.getPlotItem().items
                 if isinstance(item, pg.ScatterPlotItem)]
    np.testing.assert_array_equal(hollow.getData()[0], [5])
    np.testing.assert_allclose(hollow.getData()[1], led[4:])


def test_the_help_is_drawn_as_it_ran_beneath_the_series(tab):
    tab.exercise_choice.setCurrentIndex(0)
    figure = progress_figure(tab.progress, 0, "led_pct")
    (staircase,) = _curves(tab.help_plot)
    x, y = staircase.getOriginalDataset()
    np.testing.assert_array_equal(x, figure.help_x)
    np.testing.assert_array_equal(y, figure.help_y)
    assert {100.0, 90.0, 80.0, 70.0} <= set(y.tolist())
    texts = [item.toPlainText() for item in tab.help_plot.getPlotItem().items
             if isinstance(item, pg.TextItem)]
    assert texts == ["4 s a lap · ±20°", "3.6 s a lap"]
    assert tab.help_plot.getPlotItem().getViewBox().linkedView(0) is \
        tab.plot.getPlotItem().getViewBox()  # one trial axis


def test_the_key_is_off_the_data(tab):
    assert tab.plot.getPlotItem().legend is None
    assert tab.help_plot.getPlotItem().legend is None
    assert "did not run to its end" in tab.key.text()
    assert tab.key.geometry().bottom() < tab.plot.mapTo(tab, tab.plot.rect().topLeft()).y()


def test_progress_is_saved_as_a_pdf_page_an_exercise(qtbot, tab, tmp_path):
    assert tab.pdf_button.isEnabled()
    path = tmp_path / "progress.pdf"
    with qtbot.waitSignal(tab.pdf_saved, timeout=30000) as saved:
        tab.save_pdf(path)
    assert saved.args[0] == path
    pages = [page.extract_text() for page in PdfReader(path).pages]
    assert len(pages) == 2
    assert "As needed" in pages[0]
    assert "Thesis mode" in pages[1]


def test_a_refresh_after_a_trial_keeps_the_exercise_shown(qtbot, tab):
    tab.exercise_choice.setCurrentIndex(0)
    tab.metric_choice.setCurrentIndex(tab.metric_choice.findData("elbow_rom_rad"))
    with qtbot.waitSignal(tab.progress_loaded, timeout=10000):
        tab.refresh()
    assert tab.exercise_choice.currentIndex() == 0
    assert tab.metric_choice.currentData() == "elbow_rom_rad"


def test_the_tab_fits_a_small_screen_at_a_large_font(qtbot, qapp, tab):
    """Issue 27 #13 for this tab: at font scale 1.5 it needs no more than 1366 px across."""
    theme.apply_theme(qapp, 1.5)
    try:
        with qtbot.waitSignal(tab.progress_loaded, timeout=10000):
            tab.refresh()
        assert tab.minimumSizeHint().width() <= 1366
    finally:
        theme.apply_theme(qapp, 1.0)


@pytest.mark.parametrize("scale", [1.0, 1.5])
def test_every_figure_s_ticks_and_label_fit_beside_the_plots(qtbot, qapp, tab, scale):
    """At font scale 1.5 the help plot's label 'help (%)' lay over its tick '100': the
    axes kept 60 px whatever the font. Both plots' left axes take the room their widest
    tick and turned label need (pyqtgraph's own measure of a self-sized axis), for every
    figure of both exercises, and one width, so the trial axes line up."""
    theme.apply_theme(qapp, scale)
    try:
        tab.resize(1366, 738)
        with qtbot.waitSignal(tab.progress_loaded, timeout=10000):
            tab.refresh()
        for exercise in range(tab.exercise_choice.count()):
            tab.exercise_choice.setCurrentIndex(exercise)
            for figure in range(tab.metric_choice.count()):
                tab.metric_choice.setCurrentIndex(figure)
                qapp.processEvents()  # laid out: the axes take their widths
                tab.grab()  # painted: the axes measure the ticks they draw
                qapp.processEvents()
                tab.grab()
                axes = [plot.getPlotItem().getAxis("left")
                        for plot in (tab.plot, tab.help_plot)]
                for axis in axes:
                    needed = (axis.textWidth + axis.style["tickTextOffset"][0]
                              + max(0, axis.style["tickLength"])
                              + axis.label.boundingRect().height() * 0.8)
                    assert needed <= axis.width(), (tab.metric_choice.currentText(),
                                                    axis.labelText, needed, axis.width())
                assert axes[0].width() == axes[1].width()
    finally:
        theme.apply_theme(qapp, 1.0)


def _rows_whole(table) -> int:
    bottom = table.viewport().height()
    return sum(table.rowViewportPosition(r) >= 0
               and table.rowViewportPosition(r) + table.rowHeight(r) <= bottom
               for r in range(table.rowCount()))


def test_a_laptop_s_height_shows_the_plots_and_rows_of_the_table(tab):
    """The tab's room in a 1366 × 768 window (below the tabs' bar, above the robot bar):
    it showed one row of the table until the splitter was dragged. Now the table shows
    ROWS_SHOWN rows whole and the plots keep their readable least; a handle dragged by
    the therapist stays where it was put as the window is resized."""
    from PySide6.QtGui import QFontMetrics
    from PySide6.QtWidgets import QSplitter

    from ui.tabs.progress import HELP_LEAST_LINES, PLOT_LEAST_LINES
    from ui.views.progress_table import ROWS_SHOWN

    tab.resize(1358, 547)  # as in the window at 1366 × 768
    tab.layout().activate()
    assert _rows_whole(tab.table) >= ROWS_SHOWN
    line = QFontMetrics(tab.font()).height()
    assert tab.plot.height() >= round(PLOT_LEAST_LINES * line) - 1
    assert tab.help_plot.height() >= round(HELP_LEAST_LINES * line) - 1
    tab.resize(1900, 900)  # a tall screen: more rows
    tab.layout().activate()
    assert _rows_whole(tab.table) > ROWS_SHOWN
    splitter = tab.findChild(QSplitter)
    splitter.moveSplitter(splitter.height() - 60, 2)  # the therapist drags
    dragged = splitter.sizes()[2]
    tab.resize(1900, 880)
    tab.layout().activate()
    assert splitter.sizes()[2] == dragged


def test_an_assessment_s_series_offers_its_task_s_figures(qtbot, qapp, tmp_path):
    """The battery's position-sense runs: the chooser offered RMSE and directional
    performance, which mean little where the reference moves at the task's pace; it offers
    the task's own figures (app.reports.progress_figure.figure_rows), the first drawn."""
    from core.assessment.protocol import protocol

    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", side="right").code
    params = protocol("position").parameters(THESIS_SUBJECT)
    for error in (0.04, 0.03):
        begun = registry.begin_trial(code, params, backend="simulator")
        registry.finish_trial(begun.trial_id, "complete", {
            "position_absolute_error_m": error, "position_not_reproduced_count": 0.0,
            "rmse_x_m": 0.02, "directional_performance_pct": 40.0})
    theme.apply_theme(qapp)
    tab = ProgressTab(registry)
    shown(qtbot, tab)
    with qtbot.waitSignal(tab.progress_loaded, timeout=10000):
        tab.set_patient(code)
    offered = [tab.metric_choice.itemData(i) for i in range(tab.metric_choice.count())]
    assert offered == ["position_absolute_error_m", "position_not_reproduced_count"]
    assert tab.metric_choice.currentText() == "Absolute error (mm)"
    (line,) = _curves(tab.plot)
    np.testing.assert_allclose(line.getOriginalDataset()[1], [40.0, 30.0])


def test_markers_at_100_percent_are_drawn_whole(qtbot, qapp, tmp_path):
    """Brief hT: a trial at 100 % cut short is drawn hollow, and its ring was half cut at
    the plot's top: the axis ended 5 % of the span above 100 %, fewer pixels than the
    marker's radius on a laptop's plot. Every marker, filled or hollow, lies whole inside
    the plot, at the laptop's height and a tall screen's, and after a resize."""
    from PySide6.QtCore import QPointF

    theme.apply_theme(qapp)
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Ada", "Example", side="right").code
    number = registry.open_session(code).number
    for status, pct in (("complete", 80.0), ("complete", 100.0), ("stopped_early", 100.0),
                        ("complete", 95.0)):
        begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                     session_number=number)
        registry.finish_trial(begun.trial_id, status, {"directional_performance_pct": pct})
    tab = ProgressTab(registry)
    shown(qtbot, tab, 1358, 547)  # as in the window at 1366 × 768
    with qtbot.waitSignal(tab.progress_loaded, timeout=10000):
        tab.set_patient(code)
    assert tab.metric_choice.currentData() == "directional_performance_pct"

    def check() -> None:
        qapp.processEvents()
        box = tab.plot.getPlotItem().getViewBox()
        inside = box.sceneBoundingRect()
        markers = 0
        for item in tab.plot.getPlotItem().items:
            scatter = item.scatter if isinstance(item, pg.PlotDataItem) else item
            if not isinstance(scatter, pg.ScatterPlotItem):
                continue
            for point in scatter.points():
                centre = box.mapViewToScene(QPointF(point.pos()))
                radius = 0.5 * point.size() + point.pen().widthF()
                assert inside.top() <= centre.y() - radius, (point.pos(), point.size())
                assert centre.y() + radius <= inside.bottom(), (point.pos(), point.size())
                markers += 1
        assert markers == 4

    check()
    tab.resize(1900, 1000)
    tab.layout().activate()
    check()
    tab.resize(1358, 547)
    tab.layout().activate()
    check()


def test_hundreds_of_trials_keep_the_end_markers_and_the_pace_whole(qtbot, qapp, tmp_path):
    """A patient with 300 trials: padded by half a trial (1.3 px on a laptop's plot) the
    first and the last trial's markers were drawn half cut at the plot's ends, and the
    first trial's pace ('4 s a lap · ±20°', centred over it) was cut in half at the left."""
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("Many", "Trials").code
    n = 300
    # the pace changes at the last trial: a mark over the right end too
    many_trials(registry, code, n, lambda k: 3.0 if k == n - 1 else 4.0)
    theme.apply_theme(qapp)
    tab = shown(qtbot, ProgressTab(registry), 1366, 738)
    with qtbot.waitSignal(tab.progress_loaded, timeout=30000):
        tab.set_patient(code)
    qapp.processEvents()
    tab.grab()  # painted: the marks take their size on screen
    box = tab.plot.getPlotItem().getViewBox()
    (line,) = _curves(tab.plot)
    x, y = line.getOriginalDataset()
    assert len(x) == n
    inside = box.sceneBoundingRect()
    for end in (0, n - 1):
        centre = box.mapViewToScene(pg.Point(x[end], y[end]))
        radius = 0.5 * CUT_SHORT_PX  # room for the largest marker, whole
        assert inside.left() + radius <= centre.x() <= inside.right() - radius, end
    help_box = tab.help_plot.getPlotItem().getViewBox().sceneBoundingRect()
    texts = [item for item in tab.help_plot.getPlotItem().items
             if isinstance(item, pg.TextItem)]
    assert [t.toPlainText() for t in texts] == ["4 s a lap · ±20°", "3 s a lap"]
    for text in texts:
        drawn = text.mapRectToScene(text.boundingRect())
        assert help_box.left() <= drawn.left(), text.toPlainText()
        assert drawn.right() <= help_box.right(), text.toPlainText()
