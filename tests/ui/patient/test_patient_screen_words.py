"""The patient's words at the size the screen gives its letters (20 mm full screen on 22
inches, ui.views.patient_geometry): the top band's texts side by side, not each squeezed
into a third; the bottom's long words on two lines where the table needs no watching; the
end of an exercise with its last lap's result (seen under Xvfb: the end said "Well done!"
alone, the result worked out and never shown)."""

import dataclasses
import itertools

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st
from PySide6.QtGui import QFont, QFontMetrics

from core.trial import REPETITIONS_RANGE, THESIS_SUBJECT
from ui.patient.text import top_band, two_lines
from ui.patient.window import PatientWindow
from ui.views.patient_geometry import MIN_LETTER_MM, layout
from ui.views.patient_laps import QUALITY_ELSE, QUALITY_WORDS, lap_words
from ui.views.patient_screen import TASK_WORDS, PatientFrame

MM_PER_PX_22_INCH = 22 * 25.4 / (1920**2 + 1080**2) ** 0.5


@pytest.fixture
def full_screen(qtbot, monkeypatch):
    """The patient's window as full screen on a 22-inch 1920 × 1080 monitor."""
    window = PatientWindow()
    qtbot.addWidget(window)
    monkeypatch.setattr(window, "mm_per_px", lambda: MM_PER_PX_22_INCH)
    window.resize(1920, 1080)
    window.show_parameters(THESIS_SUBJECT.replace(repetitions=3))
    assert window.screen_layout().readable
    return window


def _painted(window, frame):
    window.frame = frame
    window.grab()
    return window.painted


def _letter_mm(window, pixel_size: int) -> float:
    bands = window.screen_layout()
    return bands.letter_mm * pixel_size / bands.text_px


def test_a_task_s_count_and_time_keep_the_screen_s_letter_size(full_screen):
    """"Target 12 of 16" fitted to a third of the band came to 71 px (13 mm)."""
    painted = _painted(full_screen, PatientFrame("Relax", False, None, None, -1, 12, 16,
                                                 40.0, blank=True, counted="Target"))
    assert painted["top"] == ("Target 12 of 16", "", "0:40 left")
    assert _letter_mm(full_screen, painted["top_px"]) >= MIN_LETTER_MM - 1e-9


@pytest.mark.parametrize("words", sorted({w for w in TASK_WORDS.values()}))
def test_the_robot_led_task_s_words_keep_the_letter_size_on_a_blank_screen(full_screen,
                                                                          words):
    """"Relax your arm: the robot moves your hand" on one line came to 14 mm, "Move your
    hand to where it was, then hold still" to 13: the screen is blank (position sense),
    so they go on two lines at the screen's size."""
    painted = _painted(full_screen, PatientFrame(words, False, None, None, -1, 3, 16, 40.0,
                                                 blank=True, counted="Target"))
    assert painted["message"] == words
    assert all(_letter_mm(full_screen, px) >= MIN_LETTER_MM - 1e-9
               for px in painted["message_px"])


def test_the_end_gives_the_last_lap_s_result_under_well_done(full_screen):
    end = PatientFrame("Well done!", False, (-0.25, 0.3), None, -1, 3, 3, 0.0,
                       result="Lap 3 done! Right on the path", success=True)
    painted = _painted(full_screen, end)
    assert painted["message"] == "Well done! Lap 3 done! Right on the path"
    assert painted["message_lines"] == ("Well done!", "Lap 3 done! Right on the path")
    assert painted["message_px"] == (full_screen.screen_layout().text_px,) * 2
    over = PatientFrame("Finished.", False, (-0.25, 0.3), None, -1, 3, 3, 0.0,
                        result="Lap 3 over: next time, follow the whole path")
    painted = _painted(full_screen, over)
    assert painted["message"] == "Finished. Lap 3 over: next time, follow the whole path"
    assert painted["message_lines"][0] == "Finished."
    # the result on two lines rather than shrunk to 13 mm on one
    assert painted["message_px"] == (full_screen.screen_layout().text_px,) * 3


def test_a_lap_under_way_keeps_its_result_on_one_line(full_screen):
    """While the hand follows the path the table's foot is not covered."""
    running = PatientFrame("", False, (-0.25, 0.3), None, -1, 2, 3, 6.0,
                           result="Now follow the whole path")
    assert _painted(full_screen, running)["message_lines"] == ("Now follow the whole path",)


@pytest.mark.parametrize("quality", [None, "", *(w for _, w in QUALITY_WORDS), QUALITY_ELSE])
def test_every_lap_s_result_keeps_the_letter_size_while_the_next_lap_runs(full_screen,
                                                                         quality):
    """Brief hT: while the next lap ran, "Lap 1 over: now follow the whole path" was
    shrunk to one line at 16 mm and "Lap 12 done! Stay closer to the path" to 17, where
    the screen promises 20. Every result, for every lap a trial can have, at 20 mm on its
    one line; at the end, on two if need be."""
    for lap in range(1, REPETITIONS_RANGE[1] + 1):
        running = PatientFrame("", False, (-0.25, 0.3), None, -1, lap + 1, lap + 1, 3.0,
                               result=lap_words(lap, quality, last=False))
        painted = _painted(full_screen, running)
        assert len(painted["message_lines"]) == 1
        assert _letter_mm(full_screen, painted["message_px"][0]) >= MIN_LETTER_MM - 1e-9, \
            painted["message"]
        end = PatientFrame("Well done!", False, (-0.25, 0.3), None, -1, lap, lap, 0.0,
                           result=lap_words(lap, quality, last=True))
        painted = _painted(full_screen, end)
        assert all(_letter_mm(full_screen, px) >= MIN_LETTER_MM - 1e-9
                   for px in painted["message_px"]), painted["message"]


@pytest.mark.parametrize("rounds", [1, 3])
def test_a_plan_s_block_keeps_the_letter_size(full_screen, rounds):
    """Brief hT: a plan's top band of block, lap and time left ("Block 2 of 3", "Lap 2 of
    3", "0:06 left") came to 18 mm, not 20: three texts side by side do not fit at 20 mm
    across 22 inches. The block is said with the trial's "Get ready" instead; the band
    and that line keep the screen's size, and a game's band (its score in the middle) is
    as large as without a plan."""
    from types import SimpleNamespace

    from app.plans.runner import PlanState

    def sizes(frame) -> tuple:
        painted = _painted(full_screen, frame)
        return (painted["top_px"], *painted["message_px"])

    # a game's frame as the band reads it: its score, the ball inside
    game = SimpleNamespace(score_text="Score 40", state=SimpleNamespace(inside=True),
                           targets=0, targets_shown=0)
    for block, blocks, laps in ((2, 3, 3), (12, 12, 20)):
        for round_ in range(1, rounds + 1):
            state = PlanState("running", block, blocks, "D shape", round_, rounds, laps, 0,
                              15, 45, 0.0, 150.0, "", "", done_share=1 / 3, lap_share=1 / 9)
            for cue, lap in (("Get ready", 0), ("", laps)):
                frame = PatientFrame(cue, False, (-0.25, 0.3), None, -1, lap, laps, 600.0)
                full_screen.show_plan(state)
                assert all(_letter_mm(full_screen, px) >= MIN_LETTER_MM - 1e-9
                           for px in sizes(frame)), full_screen.painted
                played = dataclasses.replace(frame, time_left_s=90.0, game=game)
                in_plan = sizes(played)
                full_screen.show_plan(None)
                assert in_plan == sizes(played)


TEXTS = st.text(alphabet="abc 0123456789:", max_size=18)


@settings(max_examples=60, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(texts=st.tuples(TEXTS, TEXTS, TEXTS), width=st.integers(400, 2600))
def test_the_top_band_s_texts_never_overlap_and_shrink_only_when_they_must(qapp, texts,
                                                                         width):
    font = QFont()
    font.setBold(True)
    bands = layout(width, 1080, MM_PER_PX_22_INCH)
    font.setPixelSize(bands.text_px)
    size, places = top_band(font, bands.top, texts)
    shown = [(rect, text) for rect, text in zip(places, texts, strict=True) if text]
    for rect, _ in shown:
        assert rect.left() >= bands.top.left - 1e-6
        assert rect.right() <= bands.top.left + bands.top.width + 1e-6
    for (a, _), (b, _) in itertools.pairwise(shown):
        assert a.right() <= b.left() + 1e-6  # in order, apart
    assert size <= bands.text_px
    if size < bands.text_px:  # shrunk: at the full size they would not fit side by side
        inner = 0.94 * bands.top.width
        natural = sum(QFontMetrics(font).horizontalAdvance(t) for _, t in shown)
        assert natural + 0.03 * inner * (len(shown) - 1) > inner


def test_two_lines_cut_after_a_phrase_when_that_fits(qapp):
    font = QFont()
    font.setPixelSize(100)
    assert two_lines(font, 1900, "Relax your arm: the robot moves your hand") == (
        "Relax your arm:", "the robot moves your hand")
    assert two_lines(font, 1900, "Relax") == ("Relax", "")


def test_a_rest_s_block_is_as_large_as_the_running_screen_s(full_screen):
    """The rest's and the pause's cover fitted "Block 2 of 3" to a third of the band (92 px
    of 113 full screen on 22 inches, 62 of 76 in a window) while the running screen beside
    it gave the block its full size."""
    from app.plans.runner import PlanState

    full_screen.show_plan(PlanState("resting", 2, 3, "D shape", 1, 1, 3, 0, 15, 45, 20.0,
                                    150.0, "", "", done_share=1 / 3, lap_share=1 / 9))
    full_screen.grab()
    assert full_screen.painted["top"] == ("Block 2 of 3", "", "")
    assert full_screen.painted["top_px"] == full_screen.screen_layout().text_px


@settings(max_examples=80, deadline=None)
@given(words=st.lists(st.text(alphabet="abcdefgh:,.!", min_size=1, max_size=9), min_size=1,
                      max_size=9), width=st.integers(50, 2000))
def test_two_lines_lose_no_word_and_fit_when_a_cut_can(qapp, words, width):
    font = QFont()
    font.setPixelSize(60)
    text = " ".join(words)
    first, second = two_lines(font, width, text)
    assert " ".join(line for line in (first, second) if line) == text
    metrics = QFontMetrics(font)
    cuts = [(" ".join(words[:k]), " ".join(words[k:])) for k in range(1, len(words))]
    if any(max(metrics.horizontalAdvance(a), metrics.horizontalAdvance(b)) <= width
           for a, b in cuts):
        assert max(metrics.horizontalAdvance(first), metrics.horizontalAdvance(second)) \
            <= width


@pytest.mark.parametrize("cue", ["", "Well done!"])
def test_the_figures_shown_to_the_patient_keep_clear_of_the_words(full_screen, cue):
    """*Show figures to the patient*: the two figures were painted at a third of the
    letter size over the left end of the bottom's words ("Lap 1 done! Right on the path"
    with "Off the path 4 mm" across its first word). They now stand in the table's corner,
    at half the letter size, clear of the words."""
    frame = PatientFrame(cue, False, (-0.25, 0.3), None, -1, 2, 3, 0.0 if cue else 5.0,
                         result="Lap 1 done! Right on the path", success=True,
                         numbers=("Right direction 92 %", "Off the path 4 mm"))
    painted = _painted(full_screen, frame)
    figures, words = painted["figures_at"], painted["message_at"]
    assert len(figures) == 2
    assert words
    assert not any(f.intersects(w) for f in figures for w in words)
    text_px = full_screen.screen_layout().text_px
    assert all(f.height() >= 0.5 * text_px for f in figures)  # the font's line, ≥ half
    table = full_screen.screen_layout().table
    assert all(f.top() >= table.top for f in figures)


def test_stopped_is_said_alone(full_screen):
    """A fault's record kept the lap's result under "Stopped" once the end gave results
    two lines (seen under Xvfb after the e-stop): "Stopped", nothing else."""
    frame = PatientFrame("Stopped", False, (-0.25, 0.3), None, -1, 2, 3, 8.0,
                         result="Lap 1 done! Right on the path", success=True)
    assert _painted(full_screen, frame)["message_lines"] == ("Stopped",)


@pytest.mark.parametrize("laps", [3, 10, REPETITIONS_RANGE[1]])
def test_a_game_s_lap_time_and_score_keep_the_letter_size(full_screen, laps):
    """Brief hT: a game's top band of lap, score and time left ("Lap 3 of 3", "Score 40",
    "1:30 left") came to 19.2–19.7 mm full screen on 22 inches, 17.2 with ten laps: three
    texts side by side do not fit at 20 mm. The band keeps the lap and the time left; the
    score stands at the right of the bottom, beside the game's result, at the letter size
    too, for every lap count and score a game can have (its longest time left: 120 s a
    lap). A result too long to share the line is said alone, at the letter size."""
    from types import SimpleNamespace

    text_px = full_screen.screen_layout().text_px
    most = f"Score {laps * 16 * 10}"  # every target of 16 hit, every lap
    for score in ("Score 0", "Score 40", "Score -120", most):
        game = SimpleNamespace(score_text=score, state=SimpleNamespace(inside=True),
                               targets=0, targets_shown=0)
        for result in ("", "Hit! 12.3 s", "Missed", "Clean lap! +10", "88.8 s outside"):
            for cue, lap in (("Go!", 1), ("", laps)):
                frame = PatientFrame(cue, cue == "Go!", (-0.25, 0.3), None, -1, lap, laps,
                                     120.0 * laps, result=result, game=game)
                painted = _painted(full_screen, frame)
                assert painted["top_px"] == text_px, painted["top"]
                assert painted["score"] == score, painted
                assert painted["message_px"] == (text_px,), painted
        alone = PatientFrame("", False, (-0.25, 0.3), None, -1, 2, laps, 60.0,
                             result="Keep moving round", game=game)
        painted = _painted(full_screen, alone)
        assert painted["message_px"] == (text_px,)
        assert painted["score"] in ("", score)
    end = PatientFrame("Well done! Score 40", False, (-0.25, 0.3), None, -1, laps, laps, 0.0,
                       game=game)
    assert _painted(full_screen, end)["score"] == ""  # the end's cue says it


def test_a_reaching_game_s_target_count_keeps_the_letter_size(full_screen):
    """A reaching game of one lap counts its targets in the band (16 at most,
    core.trial.TARGETS_RANGE), beside its longest time left (120 s), at the letter size."""
    from types import SimpleNamespace

    game = SimpleNamespace(score_text="Score 160", state=SimpleNamespace(inside=True),
                           targets=16, targets_shown=16)
    frame = PatientFrame("", False, (-0.25, 0.3), None, -1, 1, 1, 120.0,
                         result="Hit! 12.3 s", game=game)
    painted = _painted(full_screen, frame)
    assert painted["top"] == ("Target 16 of 16", "", "2:00 left")
    assert painted["top_px"] == full_screen.screen_layout().text_px
