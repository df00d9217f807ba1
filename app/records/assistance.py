"""The assistance levels a trial ran with, as the records keep them: the level at the
exercise's start, each change during it with its time from the exercise's start, and the
level at its end (app.trials.assistance_timeline reads them from a trial file; the
registry keeps them per trial, schema v5). Levels 0–1 inside, percent only in `summary`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

from app.errors import InvalidRecordError
from app.units import assistance_percent


@dataclass(frozen=True, slots=True)
class AssistanceInEffect:
    """The levels a trial ran with (0–1).

    `timeline` is ((0.0, level at the exercise's start), (t, level), …): the start, then
    each change during the exercise with its time from the exercise's start (s)."""

    timeline: tuple[tuple[float, float], ...]

    @property
    def at_start(self) -> float:
        """The level the exercise started at."""
        return self.timeline[0][1]

    @property
    def at_end(self) -> float:
        """The level in effect at the end of the exercise (its last tick)."""
        return self.timeline[-1][1]

    @property
    def changes(self) -> tuple[tuple[float, float], ...]:
        """The changes during the exercise, (time from its start s, new level)."""
        return self.timeline[1:]

    @property
    def changed(self) -> bool:
        return len(self.timeline) > 1

    def summary(self) -> str:
        """In plain words with display units: '100 %', or '100 % → 60 % at 5.8 s' (each
        change in turn, its time from the exercise's start)."""
        text = assistance_percent(self.at_start)
        for time_s, level in self.changes:
            text += f" → {assistance_percent(level)} at {time_s:.1f} s"
        return text

    def to_dict(self) -> dict:
        """Plain values for JSON (the registry): start, end and the changes."""
        return {"start": self.at_start, "end": self.at_end,
                "changes": [[t, level] for t, level in self.changes]}

    @classmethod
    def from_dict(cls, values: Mapping) -> AssistanceInEffect:
        """From `to_dict`'s form; InvalidRecordError naming what is wrong."""
        try:
            start = float(values["start"])
            changes = tuple((float(t), float(level))
                            for t, level in values.get("changes", ()))
        except (KeyError, TypeError, ValueError) as exc:
            raise InvalidRecordError(f"assistance levels {values!r}: give start, end and "
                                     f"changes as [[time_s, level], …] ({exc})") from None
        levels = [start, *(level for _, level in changes)]
        if not all(math.isfinite(v) and 0.0 <= v <= 1.0 for v in levels):
            raise InvalidRecordError(f"assistance levels {values!r}: each from 0 to 1")
        return cls(((0.0, start), *changes))
