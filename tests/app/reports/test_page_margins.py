"""Every text of every page of the report and of Progress stays inside the page's text
width, and within the printable page above and below: the lead saw the cut-short
report's 'Not compared' note and the Progress table run past the right margin. The texts'
boxes are read from the PDFs themselves (tests/app/reports/made.ink_boxes); the lines
are wrapped by their measured width (app.reports.pdf_sheet.wrap), which a property
holds to any words at any size."""

from __future__ import annotations

import dataclasses
import math

import matplotlib
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.font_manager import FontProperties
from matplotlib.textpath import TextToPath

from app.records.datadir import DataDir
from app.records.registry import Registry
from app.reports.build import content_for_registry_trial, write_report_pdf
from app.reports.pdf import report_pages
from app.reports.pdf_sheet import LEFT_IN, PAGE_IN, RC, RIGHT_IN, TOP_IN, fit, wrap
from app.reports.progress import progress
from app.reports.progress_pdf import write_progress_pdf
from core.trial import THESIS_SUBJECT
from tests.app.reports.made import cut, ink_boxes, register, staircase_course, with_live_change

AS_NEEDED = THESIS_SUBJECT.replace(repetitions=2, assist="as-needed")
THESIS = THESIS_SUBJECT.replace(repetitions=2)
POINTS = 72.0
SLACK_PT = 0.5  # a right-aligned text ends on the margin to a few thousandths of a point
PRINTABLE_IN = 0.2  # 5 mm: beyond the band a printer cannot print on at the paper's edge
LONG_WORD = "P1ZTTAQ/session-02/" + "x" * 160 + ".h5"


@pytest.fixture(scope="module")
def pdfs(tmp_path_factory):
    """The report of a trial in each mode, of one cut short (with earlier trials, so the
    comparison's 'Not compared' note is there), of one whose help changed during it, of
    one with many long notes (continuation pages, a word longer than a line), and the
    Progress PDF of a staircase."""
    registry = Registry(DataDir(tmp_path_factory.mktemp("data")))
    code = registry.create_patient("Ada", "Example", side="right").code
    register(registry, code, AS_NEEDED, session=1, seed=1)
    register(registry, code, AS_NEEDED, session=2, seed=2, minutes=60)
    ids = {
        "as-needed": register(registry, code, AS_NEEDED, session=2, seed=3, minutes=65),
        "cut-short": register(registry, code, AS_NEEDED, session=2, seed=4, minutes=70,
                              edit=lambda trial: cut(trial, 0.35, "faulted")),
        "live-change": register(registry, code, AS_NEEDED.replace(assistance_level=0.7),
                                session=2, seed=5, minutes=75,
                                edit=lambda trial: with_live_change(trial, 2.5, 0.6)),
    }
    register(registry, code, THESIS, session=1, seed=6, minutes=10)
    ids["thesis"] = register(registry, code, THESIS, session=2, seed=7, minutes=80)
    folder = tmp_path_factory.mktemp("pdfs")
    contents = {name: content_for_registry_trial(registry, trial_id)
                for name, trial_id in ids.items()}
    written = {name: write_report_pdf(content, folder / f"{name}.pdf")
               for name, content in contents.items()}
    written["contents"] = contents
    noted = contents["cut-short"]
    notes = tuple(f"note {k}: the patient said the handle felt heavier after the second "
                  f"lap, and asked for a rest before the next trial" for k in range(60))
    written["notes"] = write_report_pdf(
        dataclasses.replace(noted, notes=(*notes, f"the video is in {LONG_WORD}")),
        folder / "notes.pdf")
    staircase = registry.create_patient("Sam", "Example").code
    staircase_course(registry, staircase, THESIS_SUBJECT.replace(repetitions=1))
    written["progress"] = write_progress_pdf(progress(registry, staircase),
                                             folder / "progress.pdf")
    return written


@pytest.mark.parametrize("name", ["as-needed", "thesis", "cut-short", "live-change", "notes",
                                  "progress"])
def test_no_text_lies_outside_the_text_width_or_the_printable_page(pdfs, name):
    boxes = ink_boxes(pdfs[name])
    assert len(boxes) > 50  # the texts were read
    left, right = LEFT_IN * POINTS, (PAGE_IN[0] - RIGHT_IN) * POINTS
    bottom, top = PRINTABLE_IN * POINTS, (PAGE_IN[1] - TOP_IN) * POINTS
    outside = [f"page {b.page}: {b.text!r} spans x {b.left:.1f}-{b.right:.1f} pt, "
               f"y {b.bottom:.1f}-{b.top:.1f} pt"
               for b in boxes
               if b.left < left - SLACK_PT or b.right > right + SLACK_PT
               or b.bottom < bottom or b.top > top + SLACK_PT]
    assert not outside, (f"text outside x {left:.1f}-{right:.1f} pt, "
                         f"y {bottom:.1f}-{top:.1f} pt:\n" + "\n".join(outside))


@pytest.mark.parametrize("name", ["cut-short", "live-change"])
def test_the_patient_page_drawn_to_pixels_keeps_its_text_inside_the_margin(pdfs, name):
    """docs/report-example*.png are the page drawn at 80 dpi: FreeType's hinting widened
    small type there until the cut-short page's 'Not compared' note ran past the margin,
    which the PDF never did. Right of the margin (the rule and the banner's frame end on
    it, within a pixel and a half of line width) the page is blank."""
    (page, *_) = report_pages(pdfs["contents"][name])
    dpi = 80
    with matplotlib.rc_context(RC):
        canvas = FigureCanvasAgg(page)
        page.set_dpi(dpi)
        canvas.draw()
        pixels = np.asarray(canvas.buffer_rgba())[..., :3]
    margin_px = (PAGE_IN[0] - RIGHT_IN) * dpi
    beyond = pixels[:, math.ceil(margin_px + 1.5):]
    inked = np.flatnonzero((beyond < 200).any(axis=(1, 2)))
    assert inked.size == 0, f"ink right of the margin on rows {inked[:5].tolist()}…"


def test_the_long_notes_are_all_there(pdfs):
    """The word longer than a line is broken, not cut: every character of it is printed."""
    texts = "".join(b.text for b in ink_boxes(pdfs["notes"]))
    assert LONG_WORD in texts.replace(" ", "")
    assert all(f"note {k}:" in texts for k in range(60))


def _width_pt(text: str, size: float, weight: str) -> float:
    font = FontProperties(family="DejaVu Sans", size=size, weight=weight)
    return TextToPath().get_text_width_height_descent(text, font, ismath=False)[0]


# Words of the report's kinds: wide letters, narrow ones, numbers, units, arrows.
_WORDS = st.lists(st.text(alphabet="mMWwil1.,%°→–abcdefghijklmnopqrstuvxyz0123456789()·",
                          min_size=1, max_size=24), min_size=1, max_size=30)


@settings(max_examples=150, deadline=None)
@given(words=_WORDS, size=st.floats(6.0, 20.0), width_in=st.floats(0.4, 7.1),
       weight=st.sampled_from(("normal", "bold")))
def test_every_wrapped_line_fits_its_width_and_keeps_every_character(words, size, width_in,
                                                                     weight):
    text = " ".join(words)
    lines = wrap(text, size, width_in, weight)
    for line in lines:
        assert _width_pt(line, size, weight) <= width_in * POINTS + 1e-6, line
    assert "".join(lines).replace(" ", "") == text.replace(" ", "")
    # a word that fits a line is never broken
    for word in words:
        if _width_pt(word, size, weight) <= width_in * POINTS:
            assert any(word in line.split(" ") for line in lines), word


@settings(max_examples=100, deadline=None)
@given(words=_WORDS, size=st.floats(6.0, 20.0), width_in=st.floats(0.4, 7.1),
       weight=st.sampled_from(("normal", "bold")))
def test_a_fitted_cell_fits_its_width(words, size, width_in, weight):
    text = " ".join(words)
    cell = fit(text, size, width_in, weight)
    assert _width_pt(cell, size, weight) <= width_in * POINTS + 1e-6, cell
    assert cell == text or (cell.endswith("…") and text.startswith(cell[:-1].rstrip()))
