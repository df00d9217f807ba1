"""Issue 27 #8 on the screen: the Report tab's part for the patient (above "For the
therapist") says what the PDF's page 1 says, in the same order: the mode's own success
figure first, no verdict for a trial cut short, no instructions to the therapist,
coordinates, seeds or file names; the therapist's part below keeps the detail."""

from __future__ import annotations

import re

import pytest
from PySide6.QtCore import QPointF, QRect, Qt

from app.records.datadir import DataDir
from app.records.registry import Registry
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import cut, register
from tests.ui.shown import shown
from ui import theme
from ui.tabs import ReportTab

AS_NEEDED = THESIS_SUBJECT.replace(repetitions=2, assist="as-needed")


@pytest.fixture(scope="module")
def course(tmp_path_factory):
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Example", side="right").code
    complete = register(registry, code, AS_NEEDED, session=1, seed=1)
    estop = register(registry, code, AS_NEEDED, session=1, seed=2, minutes=10,
                     edit=lambda trial: cut(trial, 0.4, "faulted"))
    return registry, complete, estop


@pytest.fixture
def tab(qtbot, qapp):
    theme.apply_theme(qapp)
    return shown(qtbot, ReportTab())


def test_the_patient_part_of_a_cut_short_trial_is_for_the_patient(qtbot, tab, course):
    registry, _, estop = course
    with qtbot.waitSignal(tab.report_ready, timeout=10000) as ready:
        tab.load_registry_trial(registry, estop)
    content = ready.args[0]
    lines = tab.lines()
    split = lines.index("For the therapist")
    patient, therapist = lines[:split], lines[split:]
    text = "\n".join(patient)
    # the headline, the mode's own success figure, first under "How it went"
    assert patient[patient.index("How it went") + 1] == (
        f"You led the movement {round(content.metrics.led_pct)} % of the time.")
    assert "stopped with the emergency stop" in text
    for word in ("Clear fault", "Make sure", "seed", ".h5", "Settings"):
        assert word not in text, word
    assert not re.search(r"\(-?\d+(\.\d+)?, -?\d+(\.\d+)?\)", text)
    since = text.split("Since last time", 1)[1]
    for word in ("better", "worse", "the same", "↑", "↓"):
        assert word not in since, word
    assert "Not compared: this trial did not run to its end" in since
    # the therapist's part keeps the detail
    detail = "\n".join(therapist)
    assert "Make sure the patient is safe, then press Clear fault" in detail
    assert "seed 2" in detail
    assert content.source.name in detail
    # the line above the page names the trial, not its file
    assert tab.message.text() == "Report of session 1, trial 2"


def test_the_path_is_drawn_as_the_patient_saw_it(qtbot, tab, course):
    """As on the PDF's page 1: from the patient's seat (docs/frames.md: the patient sits on
    +y facing −y, their right is −x), no coordinates."""
    registry, complete, _ = course
    with qtbot.waitSignal(tab.report_ready, timeout=10000) as ready:
        tab.load_registry_trial(registry, complete)
    lines = tab.lines()
    assert "Your hand's path and the path to follow" in lines
    assert "Seen from your seat, as you sat at the table." in lines
    item = tab.path_plot.getPlotItem()
    box = item.getViewBox()
    centre = ready.args[0].path.outline_m.mean(axis=0) * 100.0

    def on_screen(dx_cm, dy_cm):
        return box.mapViewToScene(QPointF(centre[0] + dx_cm, centre[1] + dy_cm))

    assert on_screen(0, +5).y() > on_screen(0, -5).y()  # nearer the patient: lower
    assert on_screen(-5, 0).x() > on_screen(+5, 0).x()  # the patient's right: right
    assert not item.getAxis("left").isVisible()
    assert not item.getAxis("bottom").isVisible()


def test_the_page_fits_a_small_screen_at_a_large_font(qtbot, qapp, tab, course):
    """Issue 27 #13 for this tab: at 1366×768 and font scale 1.5 every line of the
    patient's part wraps within the view (a comparison's title once forced the page to
    2,135 px and cut the headline off at 'of the')."""
    registry, _, estop = course
    theme.apply_theme(qapp, 1.5)
    try:
        tab.resize(1366, 768)
        with qtbot.waitSignal(tab.report_ready, timeout=10000):
            tab.load_registry_trial(registry, estop)
        qtbot.wait(50)
        view = tab.page.parentWidget()
        assert tab.page.minimumSizeHint().width() <= view.width()
        assert tab.page.width() <= view.width()
    finally:
        theme.apply_theme(qapp, 1.0)


@pytest.fixture(scope="module")
def two_sessions(tmp_path_factory):
    """A trial cut short in session 2: its table has the previous trial's figures and the
    previous session's beside its own."""
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Example", side="right").code
    register(registry, code, AS_NEEDED, session=1, seed=1)
    register(registry, code, AS_NEEDED, session=2, seed=2, minutes=7 * 24 * 60)
    estop = register(registry, code, AS_NEEDED, session=2, seed=3, minutes=7 * 24 * 60 + 10,
                     edit=lambda trial: cut(trial, 0.4, "faulted"))
    return registry, estop


@pytest.mark.parametrize(("scale", "size"), [(1.0, (1366, 738)), (1.5, (1920, 1050))])
def test_the_therapist_s_table_reads_whole_on_a_laptop_and_at_a_large_font(
        qtbot, qapp, tab, two_sessions, scale, size):
    """Each row as tall as its text at the widths shown (rows measured before the table was
    laid out stood three to five lines tall, the meanings wrapped in a narrow column), the
    table as tall as all its rows, and the figures with the earlier trials' beside them
    within the view (an earlier trial's heading on one line made its column 530 px wide),
    the meanings at least MEANING_CHARS characters wide."""
    from PySide6.QtWidgets import QStyleOptionViewItem, QTableWidget

    from ui.tabs.report_table import MEANING_CHARS

    registry, estop = two_sessions
    theme.apply_theme(qapp, scale)
    try:
        tab.resize(*size)
        with qtbot.waitSignal(tab.report_ready, timeout=10000) as ready:
            tab.load_registry_trial(registry, estop)
        qtbot.wait(50)
        (table,) = tab.page.findChildren(QTableWidget)
        content = ready.args[0]
        assert len(content.table_columns) == 2  # the previous trial and the previous session
        assert table.rowCount() == len(content.table) > 10
        metrics = table.fontMetrics()
        option = QStyleOptionViewItem()
        table.initViewItemOption(option)
        for r in range(table.rowCount()):
            # as tall as its tallest cell's text wrapped at its column's width (and the
            # cells' padding: a one-line cell's height less a line), no taller
            padding = table.itemDelegate().sizeHint(option, table.model().index(r, 1)) \
                .height() - metrics.lineSpacing()
            needed = max(metrics.boundingRect(
                QRect(0, 0, table.columnWidth(c) - 8, 10_000),
                Qt.TextFlag.TextWordWrap, table.item(r, c).text()).height()
                for c in range(table.columnCount()))
            assert table.rowHeight(r) <= needed + padding + 4, (r, table.rowHeight(r), needed)
            assert needed <= 3 * metrics.lineSpacing()  # no text over more than 3 lines
        assert table.verticalScrollBar().maximum() == 0  # every row shows; the page scrolls
        shown = sum(table.rowHeight(r) for r in range(table.rowCount()))
        assert table.viewport().height() >= shown
        meaning = table.columnCount() - 1
        figures = sum(table.columnWidth(c) for c in range(meaning))
        assert figures + table.columnWidth(meaning) <= table.viewport().width() + 1
        assert table.columnWidth(meaning) >= \
            MEANING_CHARS * table.fontMetrics().averageCharWidth()
    finally:
        theme.apply_theme(qapp, 1.0)


def test_a_report_in_preparation_does_not_offer_the_previous_one(qtbot, tab, course):
    """Clinic exploration 2 #1: while the report of the trial just ended was prepared,
    the previous trial's report stayed on the page with Print and Save enabled, as if it
    were this trial's; and an older request's report, arriving while the newer one waited,
    was shown (and savable) in its place."""
    registry, complete, estop = course
    from PySide6.QtWidgets import QWidget

    def shown():
        return [w for w in tab.page.findChildren(QWidget) if w.isVisible()]

    with qtbot.waitSignal(tab.report_ready, timeout=10000):
        tab.load_registry_trial(registry, complete)
    assert tab.pdf_button.isEnabled()
    qtbot.waitUntil(lambda: bool(shown()))  # the page laid out and on the screen
    tab.load_registry_trial(registry, estop)
    assert tab.message.text() == "Preparing the report…"
    assert tab.content is None
    assert not tab.pdf_button.isEnabled()
    assert not tab.print_button.isEnabled()
    assert tab.lines() == []
    assert shown() == []  # nothing of the old page, even before its widgets are deleted
    with qtbot.waitSignal(tab.report_ready, timeout=10000):
        pass
    ready = []
    tab.report_ready.connect(ready.append)
    # two requests in a row: the first's report is not shown while the second is prepared
    tab.load_registry_trial(registry, complete)
    tab.load_registry_trial(registry, estop)
    qtbot.waitUntil(lambda: bool(ready), timeout=10000)
    qtbot.waitUntil(lambda: not tab.background.busy, timeout=10000)
    assert [content.trial_number for content in ready] == [2]
    assert tab.content.trial_number == 2
    assert tab.message.text() == "Report of session 1, trial 2"
