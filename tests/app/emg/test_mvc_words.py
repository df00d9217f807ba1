"""An MVC's quality flags in words, one map for the EMG tab and the report: every flag
core.emg.mvc raises has a short form, what it means and what to do."""

from app.emg.mvc_words import FLAG_WORDS, long_flags, short_flags, todo
from core.emg.mvc import BELOW_TRIAL, FLAGS, NO_EFFORT, SATURATED


def test_every_flag_has_its_words():
    assert set(FLAG_WORDS) == set(FLAGS)
    for words in FLAG_WORDS.values():
        assert all((words.short, words.meaning, words.todo))
        assert words.long.startswith(words.short + ": ")


def test_the_tab_says_the_short_form_the_report_the_long_one():
    assert short_flags((SATURATED, NO_EFFORT)) == "saturated, no effort above rest"
    assert long_flags((NO_EFFORT,)) == "no effort above rest: the % MVC means nothing"
    assert todo((BELOW_TRIAL,)) == "Ask for a maximal push, then record again"
    assert short_flags(("a_newer_flag",)) == "a newer flag"  # a newer file's, as named
