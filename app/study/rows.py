"""One trial file's row of a study, computed where the file is read: in a worker process.

h5py (libhdf5) is not thread-safe, so a study never shares an open file or a reading
thread between tasks: each worker process has one thread and opens every file it is given
itself, by its path (the paths a task carries must be the same on the workers as on the
machine that made the task: on a cluster, a shared folder mounted alike everywhere).

Nothing here computes a figure: the file is read by the console's reader
(app.trials.reader.read_trial, only the channels the metrics and the levels need) and
measured by the console's analysis (app.trials.analysis.analyse, as a trial's
finalization does); the metadata are the researcher's loader's row (app.exports.loader),
what the trial ran an export's columns (app.exports.run.ran_columns), and its series the
patient's progress' (app.reports.progress.exercise_of). So a study's row of a trial holds
the figures the console shows for it.

A trial from the registry is read where its file is and only when it is the file recorded
(app.exports.plan.verified_place): the data folder's, else its copy in the department's
shared trial store (schema v11), each taken only when its SHA-256 is the checksum kept at
the trial's end (schema v10); a file changed or replaced since, or in neither place, is a
failure saying which and where to restore it from, never a row of figures from a file that
is not the trial's. A file that cannot be read gives a row whose `failure` says why, in the
reader's words; the chunk goes on with the next file. A file that reads but cannot be
measured (too little exercise, no parameters) keeps its row without metrics, and its
`notes` say why, as the registry keeps such a trial. A registered trial's row names the
figures the registry holds otherwise (`registry_differs`: an earlier analysis's, which
the console shows until `rehab reanalyse` stores these).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import pandas as pd

from app.errors import AppError
from app.exports.figures import differing
from app.exports.plan import TrialSource, verified_place
from app.exports.run import ran_columns
from app.exports.trialinfo import trial_of
from app.reports.plain_language import success_key
from app.reports.progress import exercise_of
from app.study.schema import COLUMNS, METRIC_PREFIX, NUMBER, TRAILING, fits, frame
from app.trials.analysis import CHANNELS_USED, analyse_data
from app.trials.assistance_timeline import CHANNELS_NEEDED
from app.trials.reader import TrialData, read_trial
from core.errors import CoreError
from device.errors import DeviceError
from device.safewrite import folded

CHANNELS = (*CHANNELS_USED, *CHANNELS_NEEDED)
"""What a study reads of a trial's samples: what the metrics and the levels need."""

NOTES_SEPARATOR = " | "


@dataclass(frozen=True, slots=True)
class StudyTrial:
    """One trial file to analyse, with what the study knows of it before it is read (from
    the registry or the file's name). Small and plain: it travels to a worker."""

    source: TrialSource
    file: str
    """Its path relative to the study's folder (or the data folder), '/'-separated."""
    site: str | None = None
    invalid_reason: str | None = None
    """Why the registry marks it invalid; None when valid (or not known: a folder)."""

    def identity(self) -> dict:
        """The row's leading keys, known before the file is read."""
        return {"patient": self.source.participant, "site": self.site,
                "session": self.source.session, "trial": self.source.run,
                "trial_id": self.source.trial_id, "file": self.file,
                "invalid_reason": self.invalid_reason}


def analyse_trials(trials: Iterable[StudyTrial]) -> pd.DataFrame:
    """The rows of a chunk of trials as a typed frame of app.study.schema.COLUMNS: the task a
    worker runs. A file that fails is a row with its `failure`; nothing stops the chunk."""
    rows = []
    for trial in trials:
        try:
            rows.append(trial_row(trial))
        except Exception as exc:  # a damaged file, in whatever words the library said it
            rows.append({**trial.identity(), "notes": "", "failure": failure_reason(exc)})
    return frame(rows)


def failure_reason(exc: BaseException) -> str:
    """Why a file could not be analysed, on one line: the reader's own words for a file it
    refuses (it names the file and says what to do), else the library's, with a hint."""
    if isinstance(exc, AppError | DeviceError | CoreError):
        return folded(exc)
    return (f"cannot be analysed ({type(exc).__name__}: {folded(exc)}); the file may be "
            "damaged: restore it from the backup")


def trial_row(trial: StudyTrial) -> dict:
    """One trial's row (see the module's doc); raises the reader's error for a file that
    cannot be read."""
    path, note = verified_place(trial.source)
    notes = [note] if note else []
    data = read_trial(path, CHANNELS)
    loaded = trial_of(data)
    row = {key: value for key, value in loaded.row().items()
           if not key.startswith(METRIC_PREFIX)}
    notes.extend(data.notes)
    made = metrics(data, notes)
    row |= {METRIC_PREFIX + name: value for name, value in made.items()}
    if trial.source.figures is not None:  # the registry's, which the console shows
        row["registry_differs"] = ", ".join(differing(made, dict(trial.source.figures)))
    row |= ran_columns(loaded, trial.source)
    values = loaded.parameter_values
    assist = str(values.get("assist", "thesis"))
    row |= {"exercise": exercise_of(assist, values).label(), "success_metric": success_key(assist)}
    row |= {key: value for key, value in trial.identity().items() if value is not None}
    if row.get("patient") is None:
        row["patient"] = row.get("subject_code")
    return _fitted(row, notes)


def metrics(data: TrialData, notes: list[str]) -> dict[str, float]:
    """The trial's metrics as its finalization computes them (app.trials.analysis.analyse
    of the exercise phase), or none, with a note saying why, for a trial that cannot be
    measured."""
    try:
        analysis = analyse_data(data)
    except (AppError, CoreError, ValueError) as exc:  # too little exercise, data refused
        notes.append(f"no metrics: {folded(exc)}")
        return {}
    notes.extend(analysis.notes)
    return analysis.to_metrics()


def _fitted(row: dict, notes: list[str]) -> dict:
    """The row with only values its columns can hold; what is left out is noted."""
    out = {}
    for key, value in row.items():
        kind = COLUMNS.get(key)
        if kind is None or key in TRAILING:
            if key not in TRAILING and value is not None:
                notes.append(f"{key} left out: not a column of a study's table")
            continue
        if isinstance(value, float) and math.isnan(value) and kind != NUMBER:
            value = None  # not known, whatever the column's type
        if fits(value, kind):
            out[key] = value
        else:
            notes.append(f"{key} left out: {value!r} is not a {kind} value")
    out["notes"] = NOTES_SEPARATOR.join(folded(note) for note in notes)
    out["failure"] = ""
    return out
