"""What a study analyses: a folder of trial files, or the data folder's registry.

* A folder (a study's files gathered from several consoles, or a data folder's `trials/`):
  every `*.h5` file below it, in path order (app.exports.plan.sources_from_folder, as
  `rehab export --folder` walks it). The patient and the session and trial numbers come
  from the console's file names (`<code>_S003_T012_<UTC>.h5`), else the patient from the
  file's subject code. The site is `site` when given, else the first folder below the
  study's folder for a file two or more folders below it (a study laid out
  `<site>/<patient>/<file>.h5`), else unknown.
* The registry (a patient's code, or every patient): the registered trials' files
  (app.exports.plan.sources_from_registry), with the registry's ids, numbers, the
  proposal made after each and why it ended, and each file's checksum and copy in the
  shared trial store: a worker reads the data folder's file or, where that is missing or
  not the one recorded, the store's, and only a file whose SHA-256 is the one kept
  (app.exports.plan.verified_place); a researcher's machine without the stations' data
  folders reads the store. The site is `site` when given, else the
  station that recorded the trial (a department's robots on one shared registry).

Trials the registry marks invalid (`rehab invalid`) are left out and counted, unless
`include_invalid`; then each row says why it was marked (`invalid_reason`), as
`rehab progress --include-invalid` and the exports do. A folder's files are matched to the
marks and the figures of the data folder's registry, when it has one (a folder from
elsewhere has none).
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from app.errors import AppError
from app.exports.plan import (
    TrialSource,
    registry_facts,
    sources_from_folder,
    sources_from_registry,
)
from app.records.datadir import CODE_PATTERN
from app.records.store import RecordStore
from app.study.rows import StudyTrial

EVERY_PATIENT = "all"
"""The query for every patient of the registry."""
PATTERN = "**/*.h5"


@dataclass(frozen=True, slots=True)
class Selection:
    """The trials a study analyses, and what was left out."""

    trials: tuple[StudyTrial, ...]
    root: Path
    """The folder the rows' `file` is relative to (the study's folder, or the data
    folder)."""
    what: str
    """What was asked, for a line to the researcher: 'the folder …', 'patient P…'."""
    left_out_invalid: int = 0
    """Trials marked invalid that were left out (0 with include_invalid)."""
    settled: tuple[str, ...] = ()
    """A line for each trial whose file a stopped console had written into without the
    registry hearing of it, settled before it was read (app.trials.rewrite.settle_all):
    the researcher hears it, as an export's notes say it."""

    def __len__(self) -> int:
        return len(self.trials)

    @property
    def paths(self) -> tuple[Path, ...]:
        return tuple(trial.source.path for trial in self.trials)


def is_query(text: str) -> bool:
    """Whether the command's FOLDER_OR_QUERY names the registry's patients (a patient's code
    or 'all') rather than a folder: an existing folder of that name is a folder."""
    text = text.strip()
    return (CODE_PATTERN.fullmatch(text) is not None or text == EVERY_PATIENT) \
        and not os.path.isdir(text)


def from_folder(folder: str | os.PathLike, *, registry: RecordStore | None = None,
                include_invalid: bool = False, site: str | None = None) -> Selection:
    """Every trial file below `folder` (see the module's doc); `registry` the data folder's,
    for its marks, or None. AppError (one line) for a folder that is not one or holds no
    trial file."""
    root = Path(os.path.realpath(Path(folder).expanduser()))
    if not root.is_dir():
        raise AppError(f"the study folder {folder} does not exist or is not a folder: give "
                       "the folder that holds the trial files (.h5)")
    marks = _marks_by_file(registry) if registry is not None else {}
    found = sources_from_folder(root, PATTERN, known=None if registry is None
                                else registry_facts(registry))
    trials, left_out = [], 0
    for source in found:
        reason = marks.get(os.path.realpath(source.path))
        if reason is not None and not include_invalid:
            left_out += 1
            continue
        file = source.path.relative_to(root).as_posix()
        trials.append(StudyTrial(source, file, site or _site_of(file), reason))
    if not trials:
        holds = (f"only {left_out} trial(s) marked invalid (--include-invalid analyses "
                 "them)") if left_out else "no trial files (*.h5) below it"
        raise AppError(f"the study folder {root} holds {holds}: give the folder of the "
                       ".h5 trial files (a data folder's trials/, or a study's copy of them)")
    return Selection(tuple(trials), root, f"the folder {root}", left_out)


def from_registry(registry: RecordStore, query: str, *, include_invalid: bool = False,
                  site: str | None = None) -> Selection:
    """The registered trials of one patient (`query` a code) or of every patient
    ('all'); AppError (one line) when there are none, or no such patient
    (PatientNotFound)."""
    query = query.strip()
    if query == EVERY_PATIENT:
        codes = [patient.code for patient in registry.patients()]
        what = "every patient of the registry"
    else:
        registry.patient(query)  # PatientNotFound, in the registry's words
        codes = [query]
        what = f"patient {query}"
    left: list[int] = []
    settled: list[str] = []
    sources = sources_from_registry(registry, codes, include_invalid=include_invalid,
                                    left_out=left, settled=settled)
    marks = _reasons(registry) if include_invalid else {}
    root = registry.data_dir.root
    trials = tuple(StudyTrial(source, _relative(source, root), site or source.station,
                              marks.get(source.trial_id)) for source in sources)
    if not trials:
        holds = (f"only {len(left)} trial(s) marked invalid (--include-invalid analyses "
                 "them)") if left else "no trials"
        raise AppError(f"{what} has {holds} in the registry of {root}: record trials "
                       "first, or give a folder of trial files")
    return Selection(trials, root, what, len(left), tuple(settled))


def _site_of(file: str) -> str | None:
    parts = PurePosixPath(file).parts
    return parts[0] if len(parts) >= 3 else None


def _relative(source: TrialSource, root: Path) -> str:
    try:
        return source.path.relative_to(root).as_posix()
    except ValueError:
        return source.path.as_posix()


def _reasons(registry: RecordStore) -> dict[int, str]:
    """Why each trial marked invalid is (its latest mark), by trial id."""
    return {trial_id: mark.reason for trial_id, mark in registry.invalid_trials().items()}


def _marks_by_file(registry: RecordStore) -> dict[str, str]:
    """Why each trial marked invalid is, by the real path of its file."""
    return {os.path.realpath(registry.trial_path(trial_id)): reason
            for trial_id, reason in _reasons(registry).items()}

