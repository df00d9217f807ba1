"""The one line that tells the therapist a trial is saved, or why it is not: said once its
file is finished, registered and read back (ui.window.after_trial), so that the therapist
knows it is safe to go on, and where its report is.

Before it, the window said nothing when a trial was saved: the Report tab came up, but
whether the trial was in the registry, and its file the one registered, was nowhere.
"""

from __future__ import annotations

from ui.views.moment import STATUS_WORDS

REPORT_WHERE = ("Its report is on the Report tab; Save data writes it as a PDF, with the "
                "MATLAB file.")


def trial_words(number: int, session: int) -> str:
    """'Trial 3 of session 1', as the therapist's lines name a registered trial."""
    return f"Trial {number} of session {session}"


def saved_line(trial, problem_with_file: str | None) -> tuple[str, bool]:
    """(the line, whether it is a problem) for registered trial `trial`
    (app.records.registry.Trial, read back after it was finished) whose file the registry
    checked against its checksum (`problem_with_file`: Registry.verify_trial_file's words,
    None when it is the one recorded)."""
    who = trial_words(trial.number, trial.session_number)
    if not trial.finished:  # read back still recording: the finish did not reach it
        return (f"{who} is not saved: the registry still lists it as recording. Its file is "
                "kept; the console finishes it from the file when it next starts.", True)
    status = STATUS_WORDS.get(trial.status, trial.status)
    why = f": {trial.end_reason}" if trial.end_reason else ""
    if problem_with_file is not None:
        return f"{who} is registered ({status}{why}), but {problem_with_file}.", True
    if trial.status == "recording_lost":
        if trial.checksum is None:  # its file could not be read: nothing of it registered
            return (f"{who} registered as recording lost{why}: its file could not be read, "
                    "so it has no figures and no report.", True)
        return (f"{who} saved as recording lost{why}: what reached its file is registered. "
                f"{REPORT_WHERE}", True)
    if trial.checksum is None:
        return (f"{who} saved ({status}{why}), but its file could not be read for its "
                "checksum: the registry cannot prove a copy of it is this one. "
                f"{REPORT_WHERE}", True)
    return (f"{who} saved ({status}{why}): its file {trial.file.rsplit('/', 1)[-1]} is "
            f"registered and read back whole. {REPORT_WHERE}", False)


class NotSaved(Exception):
    """A trial's finishing into the registry failed: its text is the therapist's line
    (`not_saved_line`), said as the job thread's failures are."""


def not_saved_line(which: str, error: Exception) -> str:
    """The line for a trial (`which`: 'session 1, trial 3') whose finishing into the
    registry failed: what went wrong, and what becomes of it."""
    return (f"The trial ({which}) was not saved into the registry: {error}. Its file is "
            "kept; the console finishes it from the file when it next starts.")
