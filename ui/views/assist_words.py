"""What the assistance level means in each assistance mode, in the therapist's words: the
Parameters tab's label and tooltip for the one field change with the mode.

One number, two opposite meanings (issue 27 #6): in the as-needed mode (core.control.
guidance) the level scales the help along the path the robot gives when the patient falls
behind (0: the channel alone, 1: full help); in the thesis mode (core.control.assistance,
Fig. 3.6) it scales the share of a correct push the robot gives way to, which on the
thesis's stiff tracker changes the robot's torque by about 1 % at most (docs/validation.md,
Assistance). In the transparent mode (core.control.transparent) there is no level: the
robot adds no help, the field is greyed and the trial runs at 0 %.
"""

from __future__ import annotations

from dataclasses import dataclass

COMMIT = ("A new level counts when you press Enter, leave the field or use the arrows; "
          "during a trial the robot takes it then, and the trial's file records it.")


@dataclass(frozen=True, slots=True)
class LevelWords:
    label: str
    tooltip: str
    unit_meaning: str
    """What 100 % and 0 % mean, for a line under the field."""


WORDS = {
    "as-needed": LevelWords(
        "Help along the path",
        "As needed: how much the robot helps the hand along the path when the patient "
        "falls behind. 100 %: full help; 0 %: no help along the path (the robot still "
        "keeps the hand near the path). " + COMMIT,
        "100 % full help along the path, 0 % none"),
    "thesis": LevelWords(
        "Give way to a correct push",
        "Thesis mode (Fig. 3.6): the share of the patient's push in the right direction "
        "that the robot gives way to. 100 %: the thesis's full reduction; 0 %: the robot "
        "follows the path on its clock whatever the push. On this stiff tracker it changes "
        "the robot's torque by about 1 % at most. " + COMMIT,
        "100 % gives way to the whole correct push, 0 % to none"),
    "transparent": LevelWords(
        "No help in this mode",
        "Transparent: the robot only takes away its own weight and friction as far as its "
        "model allows, so the patient moves the handle as freely as it can make it, with "
        "no help and no guidance (for games, assessments and a patient who moves on their "
        "own). The safety limits stay. There is no level to set: the trial runs at 0 %.",
        "no help: the robot only lightens itself"),
}


def level_words(mode: str) -> LevelWords:
    """The level's words for an assistance mode (core.trial.ASSIST_MODES)."""
    return WORDS.get(mode, WORDS["as-needed"])
