"""The assistance level a trial ran with: where it started, every change during the
exercise and where it ended, read from what the trial file recorded, never from the form.

A trial starts at the level it was built with (`/parameters` `assistance_level`), and
the therapist may change the level while it runs (the loop takes it at the next tick).
Since the `assistance_level` channel exists (docs/data-format.md) every tick records the
level in effect; each change is also an `assistance` event with its time and level. A
file written before the channel has only the events: its levels are the parameters'
level, then each event's from its tick on.

Times are seconds from the start of the exercise (the first tick of phase 2, after the
approach to the path's start), the clock a therapist reads on the plots and the report:
a change during the approach is the level the exercise started at, one after the
exercise (the hold at its end) changes nothing the exercise did. A trial stopped before
its exercise has no exercise: its whole recording counts, from the trial's start.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np

from app.records.assistance import AssistanceInEffect

CHANNEL = "assistance_level"
"""The per-tick channel of the level in effect (device.recording.record)."""
EVENT = "assistance"
"""The event of a live change ({"level": 0.4})."""
CHANNELS_NEEDED = (CHANNEL, "phase")
"""What a partial read (app.trials.reader.read_trial(path, channels)) must include for
the timeline, besides `tick` and `time`, which every read has."""
PHASE_EXERCISE = 2

__all__ = ["CHANNEL", "CHANNELS_NEEDED", "EVENT", "AssistanceInEffect", "assistance_in_effect"]


def assistance_in_effect(
    channels: Mapping[str, np.ndarray], events: Sequence[Mapping], built_level: float,
    period_s: float, summary: Mapping | None = None,
) -> AssistanceInEffect:
    """The levels a trial ran with, from its samples (`channels`: `time`, and `phase` and
    `assistance_level` when the file has them), its `events`, the level it was built with
    and its sample period; `summary` (the file's /summary) gives the exercise's start when
    the samples' phases were not read."""
    time = np.asarray(channels.get("time", np.empty(0)), dtype=float)
    first, last = _exercise(channels, events, time, period_s, summary or {})
    recorded = channels.get(CHANNEL)
    if recorded is not None and len(recorded) == len(time) and len(time):
        return _from_channel(np.asarray(recorded, dtype=float), time, first, last,
                             built_level)
    return _from_events(events, time, first, last, built_level, period_s)


def _exercise(channels, events, time: np.ndarray, period_s: float,
              summary: Mapping) -> tuple[int, int]:
    """The first and last sample of the exercise (the whole recording when it has none;
    (0, -1) when there are no samples)."""
    n = len(time)
    if n == 0:
        return 0, -1
    phase = channels.get("phase")
    if phase is not None and len(phase) == n:
        inside = np.flatnonzero(np.asarray(phase) == PHASE_EXERCISE)
        return (int(inside[0]), int(inside[-1])) if len(inside) else (0, n - 1)
    start_s = _exercise_start_s(events, period_s, summary)
    first = int(np.searchsorted(time, start_s - 0.5 * period_s))
    return (first, n - 1) if first < n else (0, n - 1)


def _exercise_start_s(events, period_s: float, summary: Mapping) -> float:
    """Where the exercise starts without the phases: the headless run's summary, or the
    live start event's approach."""
    start = summary.get("exercise_start_s")
    if isinstance(start, int | float) and math.isfinite(start):
        return float(start)
    for event in events:
        if event.get("kind") == "start":
            ticks = (event.get("values") or {}).get("approach_ticks")
            if isinstance(ticks, int | float) and math.isfinite(ticks):
                return float(ticks) * period_s
    return 0.0


def _from_channel(levels: np.ndarray, time: np.ndarray, first: int, last: int,
                  built_level: float) -> AssistanceInEffect:
    window = levels[first:last + 1]
    known = np.flatnonzero(np.isfinite(window))
    if not len(known):
        return AssistanceInEffect(((0.0, float(built_level)),))
    values = window[known]
    origin = time[first]
    timeline = [(0.0, float(values[0]))]
    for i in np.flatnonzero(np.diff(values) != 0.0) + 1:
        timeline.append((float(time[first + known[i]] - origin), float(values[i])))
    return AssistanceInEffect(tuple(timeline))


def _from_events(events, time: np.ndarray, first: int, last: int, built_level: float,
                 period_s: float) -> AssistanceInEffect:
    """A file without the channel: the built level, then each event's from its tick on."""
    if len(time):
        origin, start_tick = time[first], round(time[first] / period_s)
        end_tick = round(time[last] / period_s)
    else:
        origin, start_tick, end_tick = 0.0, 0, 0
    level = float(built_level)
    changes = []
    for event in events:
        if event.get("kind") != EVENT:
            continue
        new = (event.get("values") or {}).get("level")
        if not isinstance(new, int | float) or not math.isfinite(new):
            continue
        tick = int(event.get("tick", 0))
        if tick <= start_tick:
            level = float(new)
        elif tick <= end_tick:
            changes.append((float(event["time_s"]) - float(origin), float(new)))
    timeline = [(0.0, level)]
    for time_s, new in changes:
        if len(timeline) > 1 and time_s == timeline[-1][0]:
            timeline.pop()  # two changes before one tick: the tick ran the second
        if new != timeline[-1][1]:
            timeline.append((time_s, new))
    return AssistanceInEffect(tuple(timeline))
