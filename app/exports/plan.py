"""Which trials an export covers, and what it produced.

A `TrialSource` is one trial file with what the export needs to name its
outputs: the stem of its files, the subfolder they go in, and, when known, the
patient's pseudonymous code and the session and trial numbers. From the
registry all of these are known; from a folder they are read from the console's
file names (``<code>_S003_T012_<UTC>.h5``, app.records.datadir.trial_stem), and files
named otherwise keep their own stem and leave the numbers to the export.
Names of people are never part of a source: the registry is asked for them only
when an export is told to include them.
"""

from __future__ import annotations

import contextlib
import fnmatch
import os
import re
from collections.abc import Callable, Collection, Iterable, Iterator, Mapping
from dataclasses import dataclass, replace
from pathlib import Path, PurePosixPath
from typing import TypeVar

from app.errors import AppError
from app.exports.files import ExportError
from app.exports.loader import Failure
from app.records.datadir import CODE_PATTERN
from app.records.outcomes import proposal_columns, trial_outcome
from app.records.registry import Trial, TrialMark
from app.records.registry.provenance import file_checksum
from app.records.store import RecordStore
from app.records.trialplace import TrialPlaces, no_file_of_its_own
from device.errors import DeviceError
from device.safewrite import folded

T = TypeVar("T")

_CONSOLE_STEM = re.compile(
    rf"(?P<code>{CODE_PATTERN.pattern})_S(?P<session>\d+)_T(?P<trial>\d+)_\d{{8}}T\d{{6}}Z"
)


@dataclass(frozen=True, slots=True)
class TrialSource:
    """One trial file to export. `folder` is the subfolder (relative, '/'-separated)
    its CSV/TSV/.mat outputs go in; '' for the export folder itself."""

    path: Path
    stem: str
    folder: str = ""
    participant: str | None = None
    session: int | None = None
    run: int | None = None
    outcome: tuple[tuple[str, object], ...] = ()
    """From the registry: the proposal made after the trial, the decision on it and why
    the trial ended (app.records.outcomes), as (column, value) pairs; () from a folder."""
    trial_id: int | None = None
    """The registry's id of the trial; None from a folder."""
    station: str | None = None
    """The station that recorded it, from the registry (schema v10); None from a folder."""
    checksum: str | None = None
    """Its file's SHA-256 kept at the trial's end (schema v10); None from a folder or for a
    trial recorded before."""
    stored_copy: str | None = None
    """Its copy in the shared trial store (`stored_in` and its file, schema v11); None when
    not copied, or from a folder."""
    figures: tuple[tuple[str, float], ...] | None = None
    """The registry's figures of the trial, which an export writes (app.exports.figures:
    `rehab reanalyse` may have re-computed them since the file was recorded); None for a
    file no registry knows."""
    invalid_reason: str | None = None
    """Why the registry marks the trial invalid (its latest mark), '' when it does not;
    None for a file no registry knows. An export names it (`invalid_reason`)."""
    no_file: str = ""
    """Why a registered row has no file of its own, '' for every other: a row finished as
    recording lost under the name of another trial's file
    (app.records.trialplace.no_file_of_its_own), whose path is that trial's recording:
    never read for it."""


@dataclass(frozen=True, slots=True)
class ExportResult:
    """What an export wrote: every file, how many trials, and the trials it could not
    read (the export goes on past them)."""

    folder: Path
    files: tuple[Path, ...]
    exported: int
    failed: tuple[Failure, ...]
    notes: tuple[str, ...] = ()
    """What the user should know, one line each: what the format could not hold (EMG in a
    BIDS dataset), earlier index rows dropped because their files are gone."""


def source_for_path(path: str | os.PathLike, folder: str = "") -> TrialSource:
    """A source for one file, with the numbers its name carries if it is a console name."""
    path = Path(path)
    match = _CONSOLE_STEM.fullmatch(path.stem)
    if match is None:
        return TrialSource(path, path.stem, folder)
    return TrialSource(path, path.stem, folder, match["code"], int(match["session"]),
                       int(match["trial"]))


def sources_from_folder(folder: str | os.PathLike, pattern: str = "**/*.h5", *,
                        leave_out: Collection[Path] = (),
                        known: Mapping[str, Mapping[str, object]] | None = None,
                        ) -> list[TrialSource]:
    """Every file matching `pattern` below `folder`, in path order, but those of
    `leave_out` (absolute paths: a data folder's trials marked invalid); the outputs of
    each go in the same relative subfolder as the file. `known` holds what a registry
    says of the trials it knows, by their file's real path (`registry_facts`)."""
    folder = Path(folder).expanduser().absolute()
    if not folder.is_dir():
        raise AppError(f"the folder {folder} does not exist or is not a folder; give the "
                       "folder that holds the trial files")
    left = {os.path.realpath(p) for p in leave_out}
    paths = sorted(p for p in _below(folder, pattern)
                   if p.is_file() and (not left or os.path.realpath(p) not in left))
    sources = [source_for_path(p, _relative_folder(p, folder)) for p in paths]
    if not known:
        return sources
    found = {os.path.realpath(p) for p in paths}
    out = []
    for source in sources:
        facts = dict(known.get(os.path.realpath(source.path), {}))
        # the name a lost row kept is the recording registered under its second name:
        # exported once, under that name, unless the folder lacks it
        if facts.pop(SAME_RECORDING_AS, None) in found:
            continue
        out.append(replace(source, **facts))
    return out


def registry_facts(registry: RecordStore) -> dict[str, dict[str, object]]:
    """What the registry says of every trial it holds, by the real path of the trial's file
    in its data folder, as TrialSource fields: its figures (app.exports.figures) and why it
    is marked invalid ('' when it is not), which a folder export of that folder writes. A
    row finished as recording lost under another trial's file name has none: that name is
    given the other trial's facts and its second name (SAME_RECORDING_AS), so the folder's
    export reads the recording once, as the trial it is."""
    marks = registry.invalid_trials()
    places = TrialPlaces(registry)
    facts: dict[str, dict[str, object]] = {}
    first_names: dict[str, Trial] = {}
    for patient in registry.patients():
        for trial in registry.trials_for_patient(patient.code):
            path = os.path.realpath(registry.trial_path(trial))
            owner = places.recording_of_name(trial, patient.code)
            if owner is not None:  # a lost row: the file of its name is the owner's
                first_names[path] = registry.trial(owner)
                continue
            facts[path] = {"figures": tuple(trial.metrics.items()),
                           "invalid_reason": marks[trial.id].reason if trial.id in marks
                           else ""}
    for path, owner in first_names.items():
        second = os.path.realpath(registry.trial_path(owner))
        facts[path] = {**facts.get(second, {}), SAME_RECORDING_AS: second}
    return facts


SAME_RECORDING_AS = "same_recording_as"
"""In `registry_facts`, beside a file name a row finished as recording lost kept
(app.records.trialplace.TrialPlaces.recording_of_name): the real path of the second name
the sync registered that recording under (app.records.station.secondname)."""


MAX_ENTRIES = 1_000_000
"""Entries a study's folder may hold below it: more is a disk, not a study (`--folder /`)."""


def _below(folder: Path, pattern: str) -> Iterator[Path]:
    """The paths below `folder` matching `pattern` ('**/NAME-PATTERN' or a glob), walked
    without following links, past folders that cannot be read or vanish meanwhile (/proc),
    and refused (AppError) past MAX_ENTRIES."""
    if not pattern.startswith("**/") or "/" in pattern[3:]:
        yield from folder.glob(pattern)
        return
    seen = 0
    for here, folders, files in os.walk(folder, onerror=lambda error: None):
        seen += len(folders) + len(files)
        if seen > MAX_ENTRIES:
            raise AppError(f"the folder {folder} holds more than {MAX_ENTRIES:,} entries: it "
                           "is not a study's folder; give the folder that holds the trial "
                           "files")
        folders.sort()
        for name in fnmatch.filter(files, pattern[3:]):
            yield Path(here, name)


def _relative_folder(path: Path, folder: Path) -> str:
    relative = path.parent.relative_to(folder).as_posix()
    return "" if relative == "." else relative


def sources_from_registry(registry: RecordStore, codes: str | Iterable[str], *,
                          include_invalid: bool = False,
                          left_out: list[int] | None = None,
                          settled: list[str] | None = None) -> list[TrialSource]:
    """Every trial of these patients, by session and trial number; each patient's
    outputs go in a subfolder named by their code. Trials marked invalid (schema v8) are
    left out unless `include_invalid`; their ids are appended to `left_out`. A write into
    a trial's file that a stopped console left unrecorded is settled first
    (app.trials.rewrite.settle_all; its lines appended to `settled`)."""
    from app.trials.rewrite import settle_all

    codes = [codes] if isinstance(codes, str) else list(codes)
    sources = []
    for code in codes:
        proposals = {p.trial_id: p for p in registry.proposals_for_patient(code)}
        marks = registry.invalid_trials(code)
        trials = registry.trials_for_patient(code)
        lines = settle_all(registry, trials)
        if lines:
            if settled is not None:
                settled += lines
            trials = registry.trials_for_patient(code)
        for trial in trials:
            if trial.id in marks and not include_invalid:
                if left_out is not None:
                    left_out.append(trial.id)
                continue
            sources.append(registry_source(registry, trial, proposals.get(trial.id), code,
                                           marks.get(trial.id)))
    return sources


def sources_of_trials(registry: RecordStore, trial_ids: Iterable[int]) -> list[TrialSource]:
    """These registered trials, in the order given, their outputs in the export folder
    itself (`rehab export --trial`); marked invalid or not, as asked. A write into a
    trial's file that a stopped console left unrecorded is settled first."""
    from app.trials.rewrite import settle_all

    trials = [registry.trial(trial_id) for trial_id in trial_ids]
    if settle_all(registry, trials):
        trials = [registry.trial(trial.id) for trial in trials]
    proposals: dict[str, dict] = {}
    for trial in trials:
        if trial.patient_code not in proposals:
            proposals[trial.patient_code] = {
                p.trial_id: p for p in registry.proposals_for_patient(trial.patient_code)}
    marks = registry.invalid_trials()
    return [registry_source(registry, trial, proposals[trial.patient_code].get(trial.id), "",
                            marks.get(trial.id))
            for trial in trials]


def registry_source(registry: RecordStore, trial: Trial, proposal, folder: str,
                    mark: TrialMark | None = None) -> TrialSource:
    """A registered trial as a source, with what the registry knows of it: its numbers,
    what followed it (`proposal`, the one made after it, or None), its file's checksum and
    store, its figures and why it is marked invalid (`mark`, its latest invalid mark, or
    None); its outputs go in `folder`."""
    outcome = trial_outcome(trial, proposal)
    return TrialSource(
        path=registry.trial_path(trial),
        stem=PurePosixPath(trial.file).stem,
        folder=folder,
        participant=trial.patient_code,
        session=trial.session_number,
        run=trial.number,
        outcome=tuple((k, outcome[k]) for k in (*proposal_columns(None), "end_reason")),
        trial_id=trial.id,
        station=trial.station,
        checksum=trial.checksum,
        stored_copy=None if trial.stored_in is None
        else os.path.join(trial.stored_in, trial.file),
        figures=tuple(trial.metrics.items()),
        invalid_reason="" if mark is None else mark.reason,
        no_file=no_file_of_its_own(registry, trial),
    )


def verified_place(source: TrialSource) -> tuple[Path, str]:
    """Where to read a registered trial's file, and a note when it is the shared trial
    store's copy: the data folder's file, else the store's (schema v11), each taken only
    when its SHA-256 is the checksum kept at the trial's end (schema v10). AppError (one
    line, each place and what is wrong with it) when no place holds the file recorded. A
    source without a checksum (a folder's, or a trial recorded before v10) is read from
    its path as it is."""
    if source.no_file:
        raise AppError(f"trial {source.trial_id}: {source.no_file}; not read")
    places = [source.path]
    if source.stored_copy is not None:
        places.append(Path(source.stored_copy))
    if source.checksum is None:
        return places[0], ""
    problems = []
    for place in places:
        try:
            found = file_checksum(place)
        except FileNotFoundError:
            problems.append(f"{place} is missing")
            continue
        except OSError as exc:
            problems.append(f"{place} cannot be read ({exc.strerror or exc})")
            continue
        if found == source.checksum:
            return place, ("" if place == places[0] else
                           f"read from the trial store's copy {place} ({problems[0]})")
        problems.append(f"{place} is not the file recorded (its SHA-256 is {found[:12]}…, "
                        f"the registry's {source.checksum[:12]}…: changed or replaced since "
                        "the trial ended)")
    if source.stored_copy is None and source.station and all(
            problem.endswith(" is missing") for problem in problems):
        # never copied to a trial store and not here: most likely on the station that
        # recorded it (a researcher's machine, another station), not lost
        raise AppError(f"trial {source.trial_id}: {'; '.join(problems)}; not read: it was "
                       f"recorded at station {source.station} and is in no trial store. Run "
                       f"this at {source.station}, copy the file from its data folder to "
                       f"{source.path}, or give the stations a shared trial store "
                       "(\"trial_store\" in settings.json: README, Several stations); "
                       "restore it from a backup if it is lost")
    raise AppError(f"trial {source.trial_id}: {'; '.join(problems)}; not read: restore the "
                   "file from a backup")


def verified_sources(sources: Iterable[TrialSource], failed: list[Failure],
                     notes: list[str]) -> list[TrialSource]:
    """The sources each at the place of its recorded file (verified_place); one that no
    place holds is listed in `failed` with why, one read from the trial store is noted."""
    out = []
    for source in sources:
        try:
            place, note = verified_place(source)
        except AppError as exc:
            failed.append(Failure(source.path, str(exc)))
            continue
        if note:
            notes.append(note)
        out.append(source if place == source.path else replace(source, path=place))
    return out


def registry_names(registry: RecordStore, codes: str | Iterable[str]) -> dict[str, tuple]:
    """{code: (first_name, last_name)}: only for exports told to include names."""
    codes = [codes] if isinstance(codes, str) else list(codes)
    names = {}
    for code in codes:
        patient = registry.patient(code)
        names[code] = (patient.first_name, patient.last_name)
    return names


def one_trial(source: Path, work: Callable[[], T], failed: list[Failure],
              outputs: Iterable[Path] = ()) -> T | None:
    """`work()`, the export of one trial of a batch; a trial it cannot export (damaged,
    unreadable, or holding what the export does not expect, in whatever words the
    library said it) is listed in `failed` with why, the files of `outputs` it began
    are removed, and the batch goes on (app.exports.run's doc). A destination that
    cannot be written (ExportError) stops the batch: every trial would fail alike."""
    outputs = [path for path in outputs if not os.path.lexists(path)]
    try:
        return work()
    except ExportError:
        raise
    except Exception as exc:  # the file's damage, in any library's words: skipped, listed
        reason = folded(exc) if isinstance(exc, AppError | DeviceError) else \
            f"cannot be exported ({type(exc).__name__}: {folded(exc)}); the file may be damaged"
        failed.append(Failure(source, reason))
        for path in outputs:
            with contextlib.suppress(OSError):
                os.unlink(path)
        return None
