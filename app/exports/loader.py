"""The researcher's loader: a trial file as named arrays with its metadata, a folder of
them as a study table.

Example (tests/app/exports/test_loader.py runs it)::

    from app.exports.loader import load_study, load_trial

    trial = load_trial("trial.h5")
    xy_m = trial["position"]                          # (N, 2): x, y in m, global frame
    print(trial.units["position"], trial.frames["position"])
    t_s = trial.channel("time", exercise_only=True)   # the exercise phase only
    print(trial.parameters.shape, trial.parameter_values["radius_m"], trial.status)
    print(trial.subject.code, trial.metrics["rmse_x_m"], len(trial.events))
    columns = trial.table()                           # flat: {"position_x_m": ..., ...}

    study = load_study("study")                       # every .h5 file below the folder
    for failure in study.failed:                      # unreadable files, and why
        print(failure.path, failure.reason)
    rmse_m = study.column("metric_rmse_x_m")          # one value per readable trial
    circles = study.where(lambda row: row["parameter_shape"] == "circle")
    for trial in circles:                             # each file is read when reached
        print(trial.path.name, trial.n_samples, trial.exercise.sum())

`Trial` behaves as a read-only mapping of channel name to array (in the file's
order) and carries `units`, `frames`, `descriptions`, `parameters` (a
`TrialParameters`, or None if the stored values no longer validate) and
`parameter_values` (the stored values as a plain dict, always there), `subject`,
`metrics`, `events`, `summary`, `status`, `notes` (what was recovered from a
file left open by a crash) and `exercise` (True in the exercise phase).
`trial.table()` gives one 1-D array per channel component, named as in the
CSV export (app.exports.columns), ready for `pandas.DataFrame(trial.table())`.

`load_study` reads only the metadata of each file (milliseconds each, no
samples) into one row per readable trial. Row keys:

* `file` (the path relative to the study folder), `status`, `seal` (how far the file
  was verified: `verified`, or `unsealed (older format)` for a file written before trial
  files were sealed, …; app.trials.reader), `created_utc`,
  `backend`, `software_version`, `format_version`, `n_samples`,
  `sample_period_s`, `recorded_s` (n_samples × sample_period_s);
* `subject_code`, `subject_body_mass_kg`, `subject_upper_arm_m`,
  `subject_forearm_m`, `subject_side`;
* `parameter_<name>` for every trial parameter, points split into x and y
  (`parameter_centre_x_m`, `parameter_centre_y_m`);
* `metric_<name>` for every metric (the prefixes keep metrics such as
  `duration_s` apart from the parameter of that name).

A key a trial lacks is None in its row. Unreadable files do not stop the walk:
`study.failed` lists each with the reason, as the console's reader gives it.
"""

from __future__ import annotations

import logging
import os
from collections.abc import Callable, Iterator
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from app.errors import AppError
from app.exports.trialinfo import (
    Trial,
    TrialInfo,
    flat_parameters,
    load_trial,
    read_info,
    trial_of,
)

__all__ = ["Failure", "Progress", "Study", "Trial", "TrialInfo", "flat_parameters",
           "load_study", "load_trial", "read_info", "trial_of"]
"""The researcher's names: the trial's own (Trial, load_trial, …) are app.exports.trialinfo's,
given here too so that one import serves a study and its trials."""

log = logging.getLogger(__name__)

Progress = Callable[[float], None]


@dataclass(frozen=True, slots=True)
class Failure:
    """A file that could not be read, and why."""

    path: Path
    reason: str


@dataclass(frozen=True, slots=True)
class Study:
    """The readable trials of a folder as rows, and the files that could not be read.
    Iterating reads the trials one at a time."""

    folder: Path
    infos: tuple[TrialInfo, ...]
    rows: tuple[dict, ...]
    failed: tuple[Failure, ...]

    def __len__(self) -> int:
        return len(self.infos)

    def __iter__(self) -> Iterator[Trial]:
        return self.trials()

    def __repr__(self) -> str:
        """What a researcher needs at the prompt, in a few lines: the dataclass's own form
        printed every row and every trial's metadata, about 100,000 characters for a small
        study."""
        patients = {row.get("subject_code") for row in self.rows} - {None}
        failed = f", {len(self.failed)} file(s) not read (.failed)" if self.failed else ""
        return (f"Study({str(self.folder)!r}: {len(self)} trial(s) of {len(patients)} "
                f"patient(s){failed}; {len(self.columns)} columns (.columns, .column(name), "
                ".table(), .rows); iterate for the trials in full)")

    @property
    def paths(self) -> tuple[Path, ...]:
        return tuple(info.path for info in self.infos)

    @property
    def columns(self) -> tuple[str, ...]:
        """Every row key, in first-seen order."""
        seen: dict[str, None] = {}
        for row in self.rows:
            seen.update(dict.fromkeys(row))
        return tuple(seen)

    def trials(self) -> Iterator[Trial]:
        """Each trial in full, read when reached (raises TrialFileError if a file
        changed since the study was loaded and can no longer be read)."""
        for info in self.infos:
            yield load_trial(info.path)

    def column(self, name: str) -> np.ndarray:
        """One row key over all trials: int64 or float64 (NaN where missing) for
        numbers, bool for flags, else an object array (None where missing)."""
        if self.rows and not any(name in row for row in self.rows):
            raise KeyError(f"the study has no column {name!r}; it has {', '.join(self.columns)}")
        return _array([row.get(name) for row in self.rows])

    def table(self) -> dict[str, np.ndarray]:
        """Every column as an array (see `column`)."""
        return {name: _array([row.get(name) for row in self.rows]) for name in self.columns}

    def where(self, keep: Callable[[dict], bool]) -> Study:
        """The trials whose row passes `keep`; `failed` stays as it is."""
        chosen = [(info, row) for info, row in zip(self.infos, self.rows, strict=True)
                  if keep(row)]
        return replace(self, infos=tuple(i for i, _ in chosen), rows=tuple(r for _, r in chosen))


def load_study(folder: str | os.PathLike, pattern: str = "**/*.h5", *,
               progress: Progress | None = None) -> Study:
    """The metadata of every file matching `pattern` below `folder`, in path order.
    Files that cannot be read are listed in `failed`, with the reason."""
    folder = Path(folder).expanduser().absolute()
    if not folder.is_dir():
        raise AppError(f"the study folder {folder} does not exist or is not a folder; "
                       "give the folder that holds the trial files")
    paths = sorted(p for p in folder.glob(pattern) if p.is_file())
    if not paths:
        raise AppError(f"the study folder {folder} holds no trial files ({pattern})"
                       f"{_what_it_holds(folder)}")
    infos, failed = [], []
    for i, path in enumerate(paths):
        try:
            infos.append(read_info(path))
        except AppError as exc:
            log.warning("study %s: %s skipped: %s", folder, path, exc)
            failed.append(Failure(path, str(exc)))
        except (OSError, RuntimeError, ValueError, KeyError, TypeError, AttributeError,
                IndexError) as exc:
            # one damaged file must not end the study: it is listed with its reason
            reason = (f"{path.name} could not be read as a trial file ({type(exc).__name__}: "
                      f"{exc}); it is left out")
            log.warning("study %s: %s", folder, reason)
            failed.append(Failure(path, reason))
        if progress is not None:
            progress((i + 1) / len(paths))
    rows = tuple(info.row(folder) for info in infos)
    return Study(folder, tuple(infos), rows, tuple(failed))


def _what_it_holds(folder: Path) -> str:
    """What a folder without trial files is, for the refusal: an export of the console
    (its trials.csv index), or nothing the console made."""
    for index in ("trials.csv", "trials.tsv"):
        if (folder / index).is_file():
            return (f": it is an export of the console: read its {index} (pandas.read_csv) "
                    "and the files it names, or give the folder of the .h5 trial files (the "
                    "data folder's trials/)")
    if (folder / "dataset_description.json").is_file():
        return (": it is a BIDS dataset: read it with a BIDS tool (pybids), or give the "
                "folder of the .h5 trial files (the data folder's trials/)")
    return ": give the folder of the .h5 trial files (the data folder's trials/)"


def _array(values: list) -> np.ndarray:
    present = [v for v in values if v is not None]
    if present and all(isinstance(v, bool | np.bool_) for v in present):
        if len(present) == len(values):
            return np.array(values, dtype=bool)
    elif present and all(isinstance(v, int | float | np.number) for v in present):
        if len(present) == len(values) and all(isinstance(v, int | np.integer)
                                               for v in present):
            return np.array(values, dtype=np.int64)
        return np.array([np.nan if v is None else v for v in values], dtype=np.float64)
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out

