"""An MVC's quality flags (core.emg.mvc) in words, once for every place that says them: the
EMG tab's rows and message line (`short`, with `todo`: what to do now) and the trial's
report (`long`: what the flag means for the % MVC read from it). The flag's reason with its
figures (core.emg.mvc.Mvc.reasons) stays in the tooltip and the log: it is a paragraph."""

from __future__ import annotations

from dataclasses import dataclass

from core.emg.mvc import BELOW_TRIAL, NO_EFFORT, SATURATED, TOO_SHORT


@dataclass(frozen=True, slots=True)
class FlagWords:
    short: str  # a few words, for a row or a line
    meaning: str  # what it means for the % MVC
    todo: str  # what the therapist does about it, before recording again

    @property
    def long(self) -> str:
        """The flag with what it means, for a report (its short words alone where the
        meaning is not known: a newer file's flag)."""
        return f"{self.short}: {self.meaning}" if self.meaning else self.short


FLAG_WORDS = {
    TOO_SHORT: FlagWords("too short", "not held near its peak for a second, a flick rather "
                         "than a maximal effort", "ask for a 3–5 s push held at its strongest"),
    SATURATED: FlagWords("saturated", "the amplifier's limit was reached, the true maximum "
                         "is unknown", "lower the gain or check the electrode's contact"),
    NO_EFFORT: FlagWords("no effort above rest", "the % MVC means nothing",
                         "check that the electrode is on the muscle and that the patient "
                         "pushes"),
    BELOW_TRIAL: FlagWords("lower than the trial's activity", "not a maximal effort, "
                           "record it again", "ask for a maximal push"),
}


def flag_words(flag: str) -> FlagWords:
    """A flag's words; one this console does not know (a newer file's) as it is named."""
    return FLAG_WORDS.get(flag) or FlagWords(flag.replace("_", " "), "", "check the recording")


def short_flags(flags) -> str:
    """'too short, saturated'."""
    return ", ".join(flag_words(f).short for f in flags)


def long_flags(flags) -> str:
    """The flags with what each means, for a report: '…; …'."""
    return "; ".join(flag_words(f).long for f in flags)


def todo(flags) -> str:
    """What to do about the flags, then record again: one short sentence."""
    text = ", and ".join(dict.fromkeys(flag_words(f).todo for f in flags)) + ", then record again"
    return text[0].upper() + text[1:]
