"""The saved line's words for each way a trial's record can stand once finished
(ui.views.saved): a record in doubt is a problem line saying why."""

from __future__ import annotations

from types import SimpleNamespace

from ui.views.saved import not_saved_line, saved_line


def _trial(**given):
    fields = dict(number=3, session_number=2, finished=True, status="complete",
                  end_reason="", checksum="a" * 64, file="P1/S02/P1_S02_T003.h5")
    fields.update(given)
    return SimpleNamespace(**fields)


def test_a_complete_trial_read_back_whole_is_saved():
    text, problem = saved_line(_trial(), None)
    assert text.startswith("Trial 3 of session 2 saved (complete): its file P1_S02_T003.h5 ")
    assert "Report tab" in text
    assert not problem


def test_a_safety_stop_is_saved_with_its_cause():
    text, problem = saved_line(_trial(status="faulted", end_reason="force limit"), None)
    assert text.startswith("Trial 3 of session 2 saved (safety stop: force limit)")
    assert not problem  # saved: the fault itself is the banner's


def test_a_file_that_is_not_the_one_registered_is_a_problem():
    text, problem = saved_line(_trial(), "its file x.h5 is not the one recorded")
    assert problem
    assert text == ("Trial 3 of session 2 is registered (complete), but its file x.h5 is "
                    "not the one recorded.")


def test_no_checksum_recording_lost_or_still_recording_are_problems():
    for trial, words in ((_trial(checksum=None), "could not be read for its checksum"),
                         (_trial(status="recording_lost", end_reason="disk full"),
                          "saved as recording lost: disk full"),
                         (_trial(status="recording_lost", end_reason="no folder",
                                 checksum=None),
                          "registered as recording lost: no folder: its file could not be "
                          "read, so it has no figures and no report"),
                         (_trial(finished=False, status="recording"),
                          "still lists it as recording")):
        text, problem = saved_line(trial, None)
        assert problem, text
        assert words in text


def test_a_failed_finish_names_the_trial_and_its_cause():
    line = not_saved_line("session 1, trial 4", OSError("no space left"))
    assert line.startswith("The trial (session 1, trial 4) was not saved into the "
                           "registry: no space left.")
