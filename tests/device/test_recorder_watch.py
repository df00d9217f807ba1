"""The loop's watch on the recorder's beat, counted in ticks (issue 28 #6): no clock."""

from dataclasses import dataclass

from hypothesis import given, strategies as st

from device.loop.recorder_watch import RECORDER_SILENT_TICKS, RecorderPulse


@dataclass
class Beat:
    value: int = 0


def test_a_recorder_that_stops_beating_is_noticed_after_exactly_the_limit():
    beat = Beat()
    pulse = RecorderPulse(beat)
    for _ in range(1000):  # a beat every 25 ticks, as the recorder's 0.05 s at 2 ms
        beat.value += 1
        assert not any(pulse.stalled() for _ in range(25))
    beat.value += 1  # its last beat
    after = [pulse.stalled() for _ in range(RECORDER_SILENT_TICKS + 5)]
    # the tick that sees the last beat, then RECORDER_SILENT_TICKS ticks without one
    assert after.index(True) == RECORDER_SILENT_TICKS
    assert all(after[RECORDER_SILENT_TICKS:])


@given(st.lists(st.integers(1, RECORDER_SILENT_TICKS - 1), min_size=1, max_size=50))
def test_beats_closer_than_the_limit_never_stop_a_trial(gaps):
    beat = Beat()
    pulse = RecorderPulse(beat)
    for gap in gaps:
        assert not any(pulse.stalled() for _ in range(gap))
        beat.value += 1


def test_each_trial_starts_its_count_afresh_and_no_beat_means_no_watch():
    beat = Beat()
    pulse = RecorderPulse(beat)
    for _ in range(RECORDER_SILENT_TICKS - 1):
        pulse.stalled()
    pulse.reset()  # a new trial: the silence between trials does not count
    assert not any(pulse.stalled() for _ in range(RECORDER_SILENT_TICKS - 1))
    assert not any(RecorderPulse(None).stalled() for _ in range(10 * RECORDER_SILENT_TICKS))
