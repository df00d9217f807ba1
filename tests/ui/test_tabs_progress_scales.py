"""The Progress tab with clinical scales (issue 31, items 2 and 3): a trial marked invalid
leaves the plots and the table and comes back when the tick box asks; a robot figure
against a scale over the sessions with the correlation; across every patient (a study)."""

from __future__ import annotations

import pyqtgraph as pg
import pytest

from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import THESIS_SUBJECT
from tests.ui.shown import shown
from ui import theme
from ui.tabs import ProgressTab
from ui.views.progress_table import LEADING_HEADINGS

RT = "rmse_x_m"


@pytest.fixture
def clinic(tmp_path):
    registry = Registry(DataDir(tmp_path / "data"))
    codes = []
    for p, offset in enumerate((0.0, 0.004)):
        code = registry.create_patient(f"P{p}", "Example", side="right").code
        codes.append(code)
        for rmse, fm in ((0.020, 18), (0.015, 26), (0.011, 35), (0.009, 41)):
            number = registry.open_session(code).number
            begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                         session_number=number)
            registry.finish_trial(begun.trial_id, "complete",
                                  {RT: rmse + offset, "directional_performance_pct": 70.0})
            registry.record_scale(code, number, "fugl_meyer", total=fm - 10 * p,
                                  rater="K. Lee")
    return registry, codes


def one_trial(tmp_path, metrics: dict) -> tuple[Registry, str, int]:
    """A registry with one patient, one session and one finished trial of `metrics`:
    the patient's code and the session's number."""
    registry = Registry(DataDir(tmp_path / "data"))
    code = registry.create_patient("P", "Example", side="right").code
    number = registry.open_session(code).number
    begun = registry.begin_trial(code, THESIS_SUBJECT, backend="simulator",
                                 session_number=number)
    registry.finish_trial(begun.trial_id, "complete", metrics)
    return registry, code, number


def opened(qtbot, registry, code: str, width: int = 1280, height: int = 900) -> ProgressTab:
    """The Progress tab shown on `code`, its progress and its scales panel loaded."""
    tab = ProgressTab(registry)
    shown(qtbot, tab, width, height)
    with qtbot.waitSignal(tab.progress_loaded, timeout=10000), \
            qtbot.waitSignal(tab.scales.shown, timeout=10000):
        tab.set_patient(code)
    return tab


@pytest.fixture
def tab(qtbot, qapp, clinic):
    theme.apply_theme(qapp)
    registry, codes = clinic
    return opened(qtbot, registry, codes[0])


def test_an_invalid_trial_disappears_from_progress_and_comes_back_when_asked(qtbot, tab,
                                                                            clinic):
    registry, codes = clinic
    assert tab.table.rowCount() == 4
    second = registry.trial_summaries(codes[0])[1].id
    registry.mark_trial(second, valid=False, reason="let go of the handle", by="K. Lee")
    with qtbot.waitSignal(tab.progress_loaded, timeout=10000):
        tab.refresh()
    assert tab.table.rowCount() == 3
    assert [t.id for t in tab.progress.trials].count(second) == 0
    with qtbot.waitSignal(tab.progress_loaded, timeout=10000), \
            qtbot.waitSignal(tab.scales.shown, timeout=10000):
        tab.include_invalid.setChecked(True)
    assert tab.table.rowCount() == 4
    status = LEADING_HEADINGS.index("Status")
    statuses = [tab.table.item(r, status).text() for r in range(4)]
    assert statuses[1].endswith("INVALID: let go of the handle")
    assert tab.scales.view.series.points[1].figure == pytest.approx(0.015)


def test_a_figure_against_the_fugl_meyer_with_its_correlation(qtbot, tab):
    tab.scales_button.click()  # in the table's place
    assert tab.lower.currentIndex() == 1
    view = tab.scales.view
    assert view.series.scale_key == "fugl_meyer"
    choice = tab.scales.figure_choice
    with qtbot.waitSignal(tab.scales.shown, timeout=10000):
        choice.setCurrentIndex(choice.findData("directional_performance_pct"))
    assert "no variation" in tab.scales.caption.text()  # 70 % at every session
    with qtbot.waitSignal(tab.scales.shown, timeout=10000):
        choice.setCurrentIndex(choice.findData(RT))
    view = tab.scales.view
    assert [p.scale for p in view.series.points] == [18, 26, 35, 41]
    assert view.series.correlation.spearman_rho == pytest.approx(-1.0)
    assert "Spearman ρ = -1.00" in tab.scales.caption.text()
    assert "n = 4" in tab.scales.caption.text()
    # its sentences begin with a capital: '…correlation. the norms…' read as a slip
    caption = tab.scales.caption.text()
    assert all(sentence[:1].isupper() for sentence in caption.split(". ")[1:]), caption
    scatter = [i for i in tab.scales.plot.getPlotItem().items
               if isinstance(i, pg.ScatterPlotItem)]
    assert len(scatter[0].data) == 4
    with qtbot.waitSignal(tab.scales.shown, timeout=10000):
        tab.scales.study.setChecked(True)
    study = tab.scales.view.series
    assert study.correlation.n == 2  # one point per patient
    assert "Study:" in tab.scales.caption.text()


def test_before_any_scale_the_panel_says_where_to_record_one_and_draws_no_empty_axes(
        qtbot, qapp, tmp_path):
    """Trying the window: a game patient's Clinical scales offered "duration_s",
    "tolerance_rad" and "game_hits" among the figures, drew empty axes under a caption
    that gave a shell command. The figures are the Progress tab's own, named; no axes
    until there is something to draw; the caption names the window's place."""
    theme.apply_theme(qapp)
    registry, code, number = one_trial(tmp_path, {
        RT: 0.01, "duration_s": 20.0, "tolerance_rad": 0.35, "game_hits": 8.0,
        "led_pct": 92.0})
    tab = opened(qtbot, registry, code)
    tab.scales_button.click()
    view = tab.scales.view
    assert set(view.figures) == {RT, "led_pct"}
    assert view.series is None
    assert not tab.scales.plot.isVisible()
    caption = tab.scales.caption.text()
    assert "no clinical scales recorded yet" in caption
    assert "Registration tab" in caption
    assert "rehab " not in caption
    assert "`" not in caption
    registry.record_scale(code, number, "fugl_meyer", total=30, rater="K. Lee")
    with qtbot.waitSignal(tab.scales.shown, timeout=10000):
        tab.refresh()
    assert tab.scales.view.series is not None
    assert tab.scales.plot.isVisible()


def test_one_session_s_point_is_drawn_on_axes_a_person_can_read(qtbot, qapp, tmp_path):
    """Seen in the window: one session with a scale, and the axis read "17.53418183452690,
    17.53418183452692, 17.53418183452694" (pyqtgraph zooms a single value to its last
    digits). Both axes span at least the unit's least span, as the Progress plots do
    (app.reports.progress_figure.value_span)."""
    from PySide6.QtWidgets import QApplication

    from app.reports.progress_figure import MIN_SPAN

    theme.apply_theme(qapp)
    registry, code, number = one_trial(tmp_path, {RT: 0.0175341818345269})
    registry.record_scale(code, number, "fugl_meyer", total=36, rater="K. Lee")
    tab = opened(qtbot, registry, code, 1366, 700)
    assert tab.scales.figure_choice.currentData() == RT  # the one figure there is
    tab.scales_button.click()
    qtbot.waitExposed(tab.scales.plot)
    QApplication.processEvents()  # pyqtgraph ranges its view as it is laid out
    (x_low, x_high), (y_low, y_high) = tab.scales.plot.getPlotItem().getViewBox().viewRange()
    assert y_high - y_low >= MIN_SPAN["mm"], (y_low, y_high)
    assert y_low < 17.534 < y_high
    assert x_high - x_low >= 1.0  # a Fugl-Meyer point of its own: its neighbours' scores
    assert x_low < 36 < x_high
