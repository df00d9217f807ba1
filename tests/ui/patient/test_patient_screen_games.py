"""The games on the patient's screen (issue 30): what it says live is what the file scores.

A reaching game and a path game run headless into trial files; their samples are fed to the
patient's window in live-sized batches. At every batch the screen's game state must be the
games' scorer fed the file's samples up to that moment, at the end the figures
`core.games.score_game` gives from the whole file; the open target is painted where the
layout puts it, a hit is said ("Hit!") and the ball turns vermillion outside the channel.
"""

import dataclasses

import numpy as np
import pytest

from app.trials.headless import simulate_to_file
from app.trials.reader import read_trial
from core.games import GameScorer, game_layout, score_game
from core.trial import THESIS_SUBJECT
from device.loop.pipeline import PHASE_EXERCISE, PHASE_HOLD
from device.recording.record import RECORD_DTYPE
from ui.patient.game_paint import TARGET
from ui.patient.window import OUTSIDE, PatientWindow
from ui.views.patient_screen import CUE_DONE, CUE_OVER
from ui.views.trialview import VIEW_CHANNELS, TrialView

BATCH = 29

REACH = THESIS_SUBJECT.replace(shape="targets", game="reach", centre_m=(-0.2, 0.35),
                               radius_m=0.08, n_targets=4, duration_s=6.0, repetitions=1,
                               time_allowed_s=1.0, n_distractors=2, assist="as-needed")
PATH = THESIS_SUBJECT.replace(game="path", repetitions=2, duration_s=3.0, assist="as-needed",
                              channel_half_width_m=0.01)


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("games")
    out = {}
    for name, params, patient in (("reach", REACH, "healthy"), ("path", PATH, "weak")):
        simulate_to_file(params, folder / f"{name}.h5", patient=patient, seed=4)
        out[name] = read_trial(folder / f"{name}.h5")
    return out


def _records(data) -> np.ndarray:
    dtype = np.dtype([(c, RECORD_DTYPE.fields[c][0]) for c in VIEW_CHANNELS])
    records = np.zeros(data.n_samples, dtype=dtype)
    for name in VIEW_CHANNELS:
        records[name] = data.channels[name]
    return records[records["phase"] > 0]


@pytest.mark.parametrize("name", ["reach", "path"])
def test_the_screen_s_game_is_the_file_s_game_at_every_moment(qtbot, files, name):
    data = files[name]
    layout = game_layout(data.parameters)
    records = _records(data)
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(900, 700)
    view = TrialView(data.parameters)
    results, hits_seen, targets_painted, outside_painted = set(), 0, 0, 0
    for end in range(BATCH, len(records) + BATCH, BATCH):
        view.append(records[end - BATCH:end])
        window.show_view(view)
        state = window.frame.game.state
        up_to = records[:min(end, len(records))]
        scorer = GameScorer(layout)
        expected = scorer.feed(up_to["time"], up_to["position"][:, 0], up_to["position"][:, 1],
                               up_to["phase"])
        if up_to["phase"][-1] == PHASE_HOLD:  # over: finished, as the file's figures
            scorer.finish()
            expected = scorer.state
        assert state == expected
        if window.frame.game.result:
            results.add(window.frame.game.result.split()[0])
        if state.last is not None and state.last.hit:
            hits_seen += 1
        if window.frame.game.open_target is not None and end % (5 * BATCH) == 0:
            image = window.grab().toImage()
            centre = window.placement().to_px(window.frame.game.open_target.centre_m)
            np.testing.assert_allclose(window.painted["target"], centre)
            cursor = np.asarray(window.painted["cursor"])
            if np.hypot(*(cursor - centre)) > window.placement().length_px(0.03):
                assert image.pixelColor(round(centre[0]), round(centre[1])) == TARGET
            targets_painted += 1
        if name == "path" and not state.inside and records["phase"][end - 1 if end <=
                                                                    len(records) else -1] \
                == PHASE_EXERCISE:
            image = window.grab().toImage()
            x, y = window.painted["cursor"]
            assert image.pixelColor(round(x), round(y)) == OUTSIDE
            outside_painted += 1
    figures = score_game(layout, data.time, data.channels["position"][:, 0],
                         data.channels["position"][:, 1], data.channels["phase"])
    state = window.frame.game.state
    assert (state.hits, state.misses, state.score) == \
        (figures.hits, figures.misses, pytest.approx(figures.score))
    # praise for points; a game without one ends in plain words
    assert window.frame.cue.startswith(CUE_DONE if figures.score > 0 else CUE_OVER)
    assert window.frame.cue.endswith(f"Score {figures.score:.0f}")
    if name == "reach":
        assert figures.hits >= 1
        assert "Hit!" in results
        assert targets_painted >= 3
    else:
        assert outside_painted >= 1  # the weak patient leaves a 1 cm channel
        assert results & {"Clean", "Keep"} or any(r[0].isdigit() for r in results)


def test_a_replay_moved_back_scores_again_from_the_start(qtbot, files):
    data = files["reach"]
    layout = game_layout(data.parameters)
    view = TrialView.from_trial(data)
    window = PatientWindow()
    qtbot.addWidget(window)
    for t in (5.0, 1.2, 3.3, 0.5, 5.9):
        view.cursor = t
        window.show_view(view)
        i = int(np.searchsorted(data.time, t, side="right"))
        expected = GameScorer(layout).feed(data.time[:i], data.channels["position"][:i, 0],
                                           data.channels["position"][:i, 1],
                                           data.channels["phase"][:i])
        assert window.frame.game.state == expected


def test_the_first_target_s_outcome_is_said_as_it_happens_not_after_go(qtbot, files):
    """The first target (1 s allowed here, 1.2 s in the plan's games) is hit or missed
    while "Go!" shows (1.5 s): its "Hit!" came only after Go!, in the real window a second
    late, as the hand went for the second target. The outcome now takes Go!'s place."""
    data = files["reach"]
    records = _records(data)
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(900, 700)
    view = TrialView(data.parameters)
    said = None
    for end in range(BATCH, len(records) + BATCH, BATCH):
        view.append(records[end - BATCH:end])
        window.show_view(view)
        frame = window.frame
        if frame.go and frame.game is not None and frame.game.result:
            window.grab()
            said = window.painted["message"]
            assert said == frame.game.result
            break
    assert said is not None
    assert said.split()[0] in ("Hit!", "Missed")


def test_the_reaching_game_s_band_counts_its_targets(qtbot, files):
    """A round of one lap round its targets said "Lap 1 of 1" from its first target to its
    last (seen in the window): the band counts the targets lit so far, on to all of them,
    the one to hit being the last counted; a game of more laps counts its laps."""
    data = files["reach"]
    layout = game_layout(data.parameters)
    onsets = np.array([target.onset_s for target in layout.targets])
    records = _records(data)
    start = records["time"][np.flatnonzero(records["phase"] == PHASE_EXERCISE)[0]]
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(900, 700)
    view = TrialView(data.parameters)
    said = []
    for end in range(BATCH, len(records) + BATCH, BATCH):
        view.append(records[end - BATCH:end])
        window.show_view(view)
        last = records[min(end, len(records)) - 1]
        if last["phase"] < PHASE_EXERCISE:
            continue
        lit = int((onsets <= last["time"] - start + 1e-9).sum())
        if lit == 0:
            continue
        assert window.frame.repetition_text == f"Target {lit} of {len(onsets)}"
        if window.frame.game.open_target is not None:
            assert window.frame.game.open_target == layout.targets[lit - 1]
        said.append(lit)
    assert said == sorted(said)  # never back
    assert said[-1] == len(onsets) == 4
    window.grab()  # painted: the band says it
    assert window.painted["top"][0] == "Target 4 of 4"
    # a plan's round resumed after a pause: its laps are counted on, as laps
    assert window.frame.counted_on(2).repetition_text == "Lap 3 of 3"
    laps = dataclasses.replace(window.frame, repetition=2, repetitions=2)
    assert laps.repetition_text == "Lap 2 of 2"


def test_the_path_game_shows_where_the_lap_s_clock_is_on_the_path(qtbot, files, tmp_path):
    """The path game, played in the transparent mode, showed the channel and the ball and
    nothing else: no cue said which way round to go, nor how fast (the handle goes where it
    is pushed). It keeps the plain exercise's ring at the reference, the lap's clock on
    the path; the reaching game still shows its own targets instead."""
    params = PATH.replace(assist="transparent", assistance_level=0.0, repetitions=1,
                          channel_half_width_m=0.02)
    simulate_to_file(params, tmp_path / "path.h5", patient="weak", seed=4)
    window = PatientWindow()
    qtbot.addWidget(window)
    window.resize(900, 700)
    for data, ring in ((read_trial(tmp_path / "path.h5"), True), (files["reach"], False)):
        records = _records(data)
        view = TrialView(data.parameters)
        exercise = np.flatnonzero(records["phase"] == PHASE_EXERCISE)
        # half-way through the first lap (the reach: its second target open)
        end = exercise[0] + int(0.5 * data.parameters.duration_s / data.sample_period_s)
        for start in range(0, end, BATCH):
            view.append(records[start:min(start + BATCH, end)])
        window.show_view(view)
        image = window.grab().toImage()
        if not ring:
            assert window.frame.target_m is None
            continue
        desired = records["position_desired"][end - 1]
        np.testing.assert_allclose(window.frame.target_m, desired)
        centre = window.placement().to_px(desired)
        np.testing.assert_allclose(window.painted["target"], centre)
        radius = window.placement().length_px(window.scene.target_radius_m)
        on_ring = [image.pixelColor(round(centre[0] + radius * np.cos(a)),
                                    round(centre[1] + radius * np.sin(a))) == TARGET
                   for a in np.linspace(0.0, 2.0 * np.pi, 24, endpoint=False)]
        assert sum(on_ring) >= 6  # the ring, where the ball does not cover it
