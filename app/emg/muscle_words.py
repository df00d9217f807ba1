"""The muscles in words, once for every place that names them: the EMG tab (its rows, plots
and prompts), the PDF report's EMG page and `rehab emg record --muscle`, which accepts the
muscles named here (`MUSCLE_WORDS`' keys, the names trial files keep them under). Without
numpy or scipy: the command line's parser imports it as it is built."""

from __future__ import annotations

MUSCLE_WORDS = {"biceps": "biceps brachii", "triceps": "triceps brachii",
                "anterior_deltoid": "anterior deltoid", "posterior_deltoid": "posterior deltoid"}
# the isometric effort that loads each muscle most, against a fixed handle or a hand
EFFORT_WORDS = {"biceps": "bend the elbow (at 90°) against the resistance",
                "triceps": "straighten the elbow (at 90°) against the resistance",
                "anterior_deltoid": "lift the arm forward (shoulder at 90°) against the "
                                    "resistance",
                "posterior_deltoid": "pull the arm back (shoulder at 90°) against the "
                                     "resistance"}


def words(muscle: str) -> str:
    """'biceps brachii' for 'biceps'; a muscle not named here (a file's own) as written."""
    return MUSCLE_WORDS.get(muscle, muscle.replace("_", " "))
