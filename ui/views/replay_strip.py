"""The line that marks a replayed trial on every tab that shows it: which trial (patient
code, session, trial, when it ran) and which moment is shown, so a past trial never looks
like a live one (issue 27 #14: Replay read "Connected" with Start green, like a trial in
progress)."""

from __future__ import annotations

import datetime
import re
from pathlib import Path

from ui.views.trialview import TrialView

_STEM = re.compile(r"(?P<code>P[0-9A-Z]{6})_S(?P<session>\d+)_T(?P<trial>\d+)_"
                   r"(?P<stamp>\d{8}T\d{6}Z)")
"""A trial file's name (app.records.datadir.trial_stem)."""


def session_and_trial(path: Path | str) -> str:
    """'session 1, trial 3' for a trial file named as the data folder names them, else the
    file's name (the status bar's words for the trial recording or just recorded)."""
    name = Path(path).name
    match = _STEM.search(name)
    if match is None:
        return name
    return f"session {int(match['session'])}, trial {int(match['trial'])}"


def which_trial(view: TrialView) -> str:
    """The trial in the therapist's words: 'P1ZTTAQ, session 1, trial 3, 03 Dec 2026
    10:15', or the file's name when it is not named as the data folder names trials. The
    numbers are the registry's when the trial was opened from it (`view.numbers`): a trial
    a station's sync renumbered keeps its file's name, and the line gave the old number."""
    name = view.source.name if view.source is not None else view.title
    match = _STEM.search(name or "")
    if match is None:
        return name or "a trial"
    started = datetime.datetime.strptime(match["stamp"], "%Y%m%dT%H%M%SZ").replace(
        tzinfo=datetime.UTC).astimezone()
    session, trial = view.numbers or (int(match["session"]), int(match["trial"]))
    return f"{match['code']}, session {session}, trial {trial}, {started:%d %b %Y %H:%M}"


def replay_line(view: TrialView) -> str:
    """'Replay, not live: <which trial>; at 5.8 s of 12.8 s'."""
    moment = ""
    if view.n and view.cursor is not None:
        elapsed = view.cursor - float(view.time[0])
        moment = f"; at {elapsed:.1f} s of {view.duration_s:.1f} s"
    return f"Replay, not live: {which_trial(view)}{moment}"
