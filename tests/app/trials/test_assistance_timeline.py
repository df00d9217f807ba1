"""The assistance levels a trial ran with, as the file recorded them (issue 27, item 3):
per tick in the `assistance_level` channel, or, in a file written before it, the built
level and the `assistance` events."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings, strategies as st

from app.trials.assistance_timeline import AssistanceInEffect, assistance_in_effect
from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.recording.record import CHANNELS, RECORD_DTYPE
from device.recording.trialfile import SubjectInfo, write_trial

PERIOD_S = 0.002


def _samples(phases: list[int]) -> dict:
    n = len(phases)
    return {"tick": np.arange(n), "time": np.arange(n) * PERIOD_S,
            "phase": np.asarray(phases, dtype=np.uint8)}


def _event(tick: int, level: float) -> dict:
    return {"time_s": tick * PERIOD_S, "tick": tick, "kind": "assistance",
            "message": f"assistance level set to {level:.0%}", "values": {"level": level}}


def test_a_trial_without_a_change_ran_at_its_built_level_throughout():
    channels = _samples([1] * 10 + [2] * 50 + [3] * 5)
    channels["assistance_level"] = np.full(65, 0.7)
    ran = assistance_in_effect(channels, [], 1.0, PERIOD_S)
    assert ran.timeline == ((0.0, 0.7),)
    assert (ran.at_start, ran.at_end, ran.changed) == (0.7, 0.7, False)
    assert ran.summary() == "70 %"


def test_changes_are_timed_from_the_exercise_start_and_only_during_it():
    # 10 ticks of approach, 100 of exercise, 10 of hold; the level changes in the
    # approach (to 0.9), at exercise ticks 40 (0.6) and 70 (0.8), and in the hold (0.1)
    levels = np.ones(120)
    levels[5:] = 0.9
    levels[50:] = 0.6
    levels[80:] = 0.8
    levels[115:] = 0.1
    channels = _samples([1] * 10 + [2] * 100 + [3] * 10)
    channels["assistance_level"] = levels
    ran = assistance_in_effect(channels, [], 1.0, PERIOD_S)
    assert ran.at_start == 0.9
    assert ran.at_end == 0.8
    assert [(round(t, 6), v) for t, v in ran.changes] == [(0.08, 0.6), (0.14, 0.8)]
    assert ran.summary() == "90 % → 60 % at 0.1 s → 80 % at 0.1 s"


def test_an_older_file_reads_its_built_level_and_its_events():
    channels = _samples([1] * 10 + [2] * 100 + [3] * 10)
    events = [{"time_s": 0.0, "tick": 0, "kind": "start", "message": "", "values": {}},
              _event(3, 0.9), _event(60, 0.4), _event(115, 0.2)]
    ran = assistance_in_effect(channels, events, 1.0, PERIOD_S)
    assert ran.timeline[0] == (0.0, 0.9)
    assert [(round(t, 6), v) for t, v in ran.changes] == [(0.1, 0.4)]
    assert ran.at_end == 0.4


def test_without_the_phases_the_exercise_starts_where_the_summary_or_start_event_says():
    channels = {"tick": np.arange(100), "time": np.arange(100) * PERIOD_S,
                "assistance_level": np.r_[np.ones(50), np.full(50, 0.5)]}
    by_summary = assistance_in_effect(channels, [], 1.0, PERIOD_S,
                                      {"exercise_start_s": 20 * PERIOD_S})
    assert [(round(t, 6), v) for t, v in by_summary.changes] == [(0.06, 0.5)]
    start = {"time_s": 0.0, "tick": 0, "kind": "start", "message": "",
             "values": {"approach_ticks": 40}}
    by_event = assistance_in_effect(channels, [start], 1.0, PERIOD_S)
    assert [(round(t, 6), v) for t, v in by_event.changes] == [(0.02, 0.5)]


def test_a_trial_stopped_in_its_approach_counts_its_whole_recording():
    channels = _samples([1] * 30)
    channels["assistance_level"] = np.r_[np.full(10, 1.0), np.full(20, 0.3)]
    ran = assistance_in_effect(channels, [], 1.0, PERIOD_S)
    assert (ran.at_start, ran.at_end) == (1.0, 0.3)


def test_the_registry_form_round_trips():
    ran = AssistanceInEffect(((0.0, 1.0), (5.8, 0.6), (9.25, 0.8)))
    assert AssistanceInEffect.from_dict(ran.to_dict()) == ran
    assert ran.to_dict() == {"start": 1.0, "end": 0.8, "changes": [[5.8, 0.6], [9.25, 0.8]]}


@settings(max_examples=60, deadline=None)
@given(approach=st.integers(0, 20), exercise=st.integers(1, 200), hold=st.integers(0, 20),
       changes=st.lists(st.tuples(st.integers(0, 239), st.sampled_from([0.0, 0.25, 0.6, 1.0])),
                        max_size=8),
       built=st.sampled_from([0.0, 0.5, 1.0]))
def test_the_channel_and_the_events_tell_the_same_levels(approach, exercise, hold, changes,
                                                         built):
    """Invariant: the timeline rebuilds the per-tick level over the exercise, and a file
    without the channel (its events only) reads the same timeline."""
    n = approach + exercise + hold
    levels = np.full(n, built)
    events = []
    for tick, level in sorted(changes):
        if tick < n:
            levels[tick:] = level
            events.append(_event(tick, level))
    channels = _samples([1] * approach + [2] * exercise + [3] * hold)
    with_channel = dict(channels, assistance_level=levels)
    ran = assistance_in_effect(with_channel, events, built, PERIOD_S)
    step = np.empty(exercise)
    times = np.arange(exercise) * PERIOD_S
    for t, level in ran.timeline:
        step[times >= t - 1e-12] = level
    assert np.array_equal(step, levels[approach:approach + exercise])
    from_events = assistance_in_effect(channels, events, built, PERIOD_S).timeline
    assert np.allclose(from_events, ran.timeline, rtol=0.0, atol=1e-12)


def test_a_trial_file_gives_what_ran(tmp_path):
    """TrialData.assistance_timeline on a file: the channel when it has it."""
    records = np.zeros(300, dtype=RECORD_DTYPE)
    records["tick"] = np.arange(300)
    records["time"] = np.arange(300) * PERIOD_S
    records["phase"] = np.r_[np.ones(50), np.full(200, 2), np.full(50, 3)]
    if "assistance_level" in RECORD_DTYPE.names:
        records["assistance_level"] = np.r_[np.ones(150), np.full(150, 0.6)]
    params = THESIS_SUBJECT.replace(assistance_level=1.0)
    path = write_trial(tmp_path / "t.h5", records, parameters=params,
                       subject=SubjectInfo.from_parameters("S", params), robot={},
                       backend="test", sample_period_s=PERIOD_S, channels=CHANNELS,
                       events=[_event(150, 0.6)])
    data = read_trial(path)
    assert np.allclose(data.assistance_timeline(), ((0.0, 1.0), (0.2, 0.6)))
    ran = data.assistance_in_effect()
    assert (ran.at_start, ran.at_end, ran.summary()) == (1.0, 0.6, "100 % → 60 % at 0.2 s")
