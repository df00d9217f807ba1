"""Exports for researchers: one trial, a patient's trials, or a folder of them, as CSV,
TSV, MATLAB .mat or a BIDS-motion dataset.

Formats (each module's doc has the details):

* ``csv`` / ``tsv`` (app.exports.table): ``<stem>.csv`` with one row per sample and
  one column per channel component (``position_x_m``), one header line (the units
  in the side file ``_columns``), every value exact unless `digits` is given; side files
  ``<stem>_columns``, ``_events``, ``_metrics`` and ``_trial`` (metadata and
  parameters);
* ``mat`` (app.exports.mat): ``<stem>.mat``, v5, compressed, with the HDF5 file's
  names (``timeseries.position``, ``units``, ``frames``, ``parameters``…);
* ``bids`` (app.exports.bids): a BIDS 1.9 dataset with the motion extension.

`exercise_only=True` keeps only the samples of the exercise phase (CSV/TSV/.mat;
a BIDS run is always the whole recording, with its events).

Batch exports (`export_patient`, `export_patients`, `export_folder`, `export_trials`;
`export_registered` puts them in the folder itself) put each trial's files in a subfolder
(the patient's code, or the trial file's own subfolder of the source folder) and write
``trials.csv`` (``trials.tsv`` for TSV), one row per exported trial with its metadata and
metrics (app.exports.loader's row keys, after `participant`, `session`, `trial` and
`export_file`), then what the trial ran and what followed it (app.records.outcomes: the
assistance mode, the levels as built and as they ran, the proposal and its decision, why
it ended), `metrics_source` and `invalid_reason` (why the registry marks it invalid: ''
when it does not or no registry knows it; with include_invalid such trials are exported,
and named). A registered trial's figures are the registry's, which `rehab reanalyse` may
have re-computed since its file was recorded (app.exports.figures: `metrics_source` says
whose, and the file's own go beside them). A trial file that cannot be read is skipped
and listed in the result's `failed`; `progress(fraction)` is called as trials are done.
Exporting into a folder that holds an earlier export adds to it, as a BIDS export does:
the index (and names.csv) keeps the rows of the other trials whose files are still there
(app.exports.index).

Privacy: exports hold pseudonymous codes, never names, and every file name is
built from codes and numbers. With `include_names=True` (registry exports only)
the names go in one place: ``names.csv`` (participant, first_name, last_name) for
CSV/TSV/.mat, the first_name and last_name columns of participants.tsv for BIDS.

Safety: nothing is overwritten unless `overwrite=True` — an export that would
replace a trial's file is refused before anything is written — and every file is
written under a temporary name and moved into place when complete. A
destination that cannot be written raises ExportError naming the folder.
"""

from __future__ import annotations

import dataclasses
import logging
import os
from collections.abc import Callable, Collection, Iterable, Mapping
from pathlib import Path

from app.exports.bids import export_bids
from app.exports.columns import check_digits
from app.exports.figures import (
    INVALID_COLUMN,
    REGISTRY,
    SOURCE_COLUMN,
    registry_note,
    standing_figures,
)
from app.exports.files import (
    ExportError,
    OutputExistsError,
    prepare_folder,
    refuse_existing,
)
from app.exports.index import check_mergeable, write_index, write_names
from app.exports.loader import Failure
from app.exports.mat import write_mat
from app.exports.plan import (
    ExportResult,
    TrialSource,
    one_trial,
    registry_names,
    source_for_path,
    sources_from_folder,
    sources_from_registry,
    sources_of_trials,
    verified_sources,
)
from app.exports.table import table_outputs, write_table
from app.exports.trialinfo import Trial, load_trial
from app.records.outcomes import OUTCOME_COLUMNS, level_columns, proposal_columns
from app.records.store import RecordStore
from app.trials.assistance_timeline import assistance_in_effect

__all__ = [
    "FORMATS",
    "ExportError",
    "ExportResult",
    "OutputExistsError",
    "TrialSource",
    "export_bids",
    "export_folder",
    "export_patient",
    "export_patients",
    "export_registered",
    "export_trial",
    "export_trials",
]

log = logging.getLogger(__name__)

FORMATS = ("csv", "tsv", "mat", "bids")
Progress = Callable[[float], None]


def export_trial(
    source: Trial | str | os.PathLike,
    folder: str | os.PathLike,
    *,
    format: str = "csv",
    stem: str | None = None,
    exercise_only: bool = False,
    digits: int | None = None,
    overwrite: bool = False,
) -> tuple[Path, ...]:
    """Export one trial (a loaded Trial or a trial file) as CSV, TSV or .mat into
    `folder`; files are named `stem` (default: the trial file's). Returns the paths."""
    _check_format(format, allowed=("csv", "tsv", "mat"))
    check_digits(digits)
    trial = source if isinstance(source, Trial) else load_trial(source)
    folder = prepare_folder(folder)
    stem = stem or trial.path.stem
    refuse_existing(_outputs(format, folder, stem), overwrite)
    return _write(trial, format, folder, stem, exercise_only, digits, overwrite)


def export_trials(
    sources: Iterable[TrialSource | str | os.PathLike],
    folder: str | os.PathLike,
    *,
    format: str = "csv",
    names: Mapping[str, tuple[str | None, str | None]] | None = None,
    exercise_only: bool = False,
    digits: int | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> ExportResult:
    """Export many trials into `folder` (see the module's doc for the layout).
    `names` ({code: (first, last)}) is written only to names.csv / participants.tsv."""
    _check_format(format)
    check_digits(digits)
    sources = [s if isinstance(s, TrialSource) else source_for_path(s) for s in sources]
    if format == "bids":
        if exercise_only or digits is not None:
            raise ExportError("a BIDS run is always the whole recording with every value "
                              "exact: exercise_only and digits apply to csv, tsv and mat only")
        return export_bids(sources, folder, names=names, overwrite=overwrite, progress=progress)
    root = prepare_folder(folder)
    suffix = ".tsv" if format == "tsv" else ".csv"
    index = root / f"trials{suffix}"
    names_file = root / f"names{suffix}"
    planned = {source: _outputs(format, root / source.folder, source.stem) for source in sources}
    _refuse_duplicates(planned)
    # the index and the names file add to an earlier export's (app.exports.index)
    refuse_existing([p for paths in planned.values() for p in paths], overwrite)
    for merged in (index, *([names_file] if names else [])):
        check_mergeable(merged, suffix, overwrite)

    written: list[Path] = []
    rows: list[dict] = []
    failed: list[Failure] = []
    if progress is not None:
        progress(0.0)
    for i, (source, paths) in enumerate(planned.items()):
        def export(source=source):
            recorded = load_trial(source.path)
            # the registry's figures where `rehab reanalyse` re-computed them since
            trial, figures_from = standing_figures(
                recorded, None if source.figures is None else dict(source.figures))
            about = {SOURCE_COLUMN: figures_from, INVALID_COLUMN: source.invalid_reason or ""}
            row = {**trial.row(), **ran_columns(trial, source), **about}  # before any file
            files = _write(trial, format, root / source.folder, source.stem, exercise_only,
                           digits, overwrite, recorded.metrics, about)
            return row, files

        done = one_trial(source.path, export, failed, paths)
        if done is not None:
            row, files = done
            written += files
            rows.append({"participant": source.participant, "session": source.session,
                         "trial": source.run,
                         "export_file": paths[0].relative_to(root).as_posix(), **row})
        if progress is not None:
            progress((i + 1) / len(planned))
    notes: list[str] = []
    from_registry = sum(row[SOURCE_COLUMN] == REGISTRY for row in rows)
    if from_registry:
        notes.append(registry_note(from_registry))
    written.append(write_index(index, rows, suffix, overwrite, notes))
    if names:
        written.append(write_names(names_file, names, suffix, overwrite))
    log.info("%s export to %s: %d trial(s), %d file(s) written, %d trial(s) unreadable",
             format, root, len(rows), len(written), len(failed))
    return ExportResult(root, tuple(written), len(rows), tuple(failed), tuple(notes))


def export_patients(
    registry: RecordStore,
    codes: Iterable[str],
    folder: str | os.PathLike,
    *,
    format: str = "csv",
    include_names: bool = False,
    exercise_only: bool = False,
    digits: int | None = None,
    overwrite: bool = False,
    progress: Progress | None = None,
    include_invalid: bool = False,
) -> ExportResult:
    """Export every trial of these patients from the registry (one subfolder per
    patient code for CSV/TSV/.mat; one BIDS participant each). Trials marked invalid are
    left out, and a note says how many, unless `include_invalid`."""
    if include_names and getattr(registry, "research", False):
        # the research role reads every name as '' (the server's views): an export asked for
        # names would have written empty name columns as if the patients had none
        raise ExportError(
            "this login is a researcher's: it never reads names, so an export with names "
            "cannot be made through it. Nothing was written. Export without --include-names, "
            "or ask a clinic login for one with names")
    codes = list(codes)
    left_out: list[int] = []
    notes: list[str] = []
    sources = sources_from_registry(registry, codes, include_invalid=include_invalid,
                                    left_out=left_out, settled=notes)
    names = registry_names(registry, codes) if include_names else None
    result = _export_verified(sources, folder, notes, format=format, names=names,
                              exercise_only=exercise_only, digits=digits,
                              overwrite=overwrite, progress=progress)
    return with_invalid_note(result, len(left_out))


def export_registered(registry: RecordStore, trial_ids: Iterable[int],
                      folder: str | os.PathLike, **options) -> ExportResult:
    """Export these registered trials (`rehab export --trial`), marked invalid or not, as
    asked, into `folder` itself; each read where its recorded file is, with the registry's
    figures, as `export_patients` reads a patient's. Options as for `export_trials`."""
    notes: list[str] = []
    sources = sources_of_trials(registry, trial_ids)
    return _export_verified(sources, folder, notes, **options)


def _export_verified(sources: list[TrialSource], folder: str | os.PathLike,
                     notes: list[str], **options) -> ExportResult:
    """Export registered trials each read where the one recorded is (the data folder's
    file, else the trial store's copy): a file changed since its trial ended is listed,
    never exported as the trial. `notes` (what came before) lead the result's."""
    unverified: list[Failure] = []
    sources = verified_sources(sources, unverified, notes)
    result = export_trials(sources, folder, **options)
    return dataclasses.replace(result, failed=(*unverified, *result.failed),
                               notes=(*result.notes, *notes))


def with_invalid_note(result: ExportResult, left_out: int) -> ExportResult:
    """The result with a note of the trials marked invalid it left out, if any."""
    if not left_out:
        return result
    return dataclasses.replace(result, notes=(*result.notes, (
        f"{left_out} trial(s) marked invalid left out (`rehab trials CODE` says why); "
        "--include-invalid exports them too")))


def export_patient(
    registry: RecordStore,
    code: str,
    folder: str | os.PathLike,
    **options,
) -> ExportResult:
    """Export every trial of one patient (options as for `export_patients`)."""
    return export_patients(registry, [code], folder, **options)


def export_folder(
    source_folder: str | os.PathLike,
    folder: str | os.PathLike,
    *,
    pattern: str = "**/*.h5",
    leave_out: Collection[Path] = (),
    known: Mapping[str, Mapping[str, object]] | None = None,
    **options,
) -> ExportResult:
    """Export every trial file matching `pattern` below `source_folder` (a study) but
    those of `leave_out` (a data folder's trials marked invalid: a note says how many
    were below the folder): CSV/TSV/.mat outputs mirror its subfolders. `known`: what the
    data folder's registry says of its trials (app.exports.plan.registry_facts: their
    figures, written in place of the files' own, and their invalid marks). Options as for
    `export_trials`.
    ExportError, with nothing written, for a folder with no trial file to export (a
    wrong folder would otherwise make an empty export)."""
    found = sources_from_folder(source_folder, pattern, known=known)
    left = {os.path.realpath(p) for p in leave_out}
    sources = [s for s in found if os.path.realpath(s.path) not in left]
    below = len(found) - len(sources)
    if not sources:
        root = Path(os.path.realpath(source_folder))
        holds = (f"only {below} trial(s) marked invalid (--include-invalid exports them)"
                 if below else f"no trial files ({pattern.removeprefix('**/')}) below it")
        raise ExportError(f"the folder {root} holds {holds}. Nothing was written. Give the "
                          "folder of the .h5 trial files (a data folder's trials/, or a "
                          "study's copy of them)")
    return with_invalid_note(export_trials(sources, folder, **options), below)


# -- helpers -------------------------------------------------------------------


def ran_columns(trial: Trial, source: TrialSource) -> dict:
    """trials.csv's columns of what the trial ran and what followed it
    (app.records.outcomes.OUTCOME_COLUMNS): the mode and the levels from its file, the
    proposal and its decision from the registry (empty from a folder), why it ended from
    the registry or else the file's last fault."""
    values = trial.parameter_values
    built = values.get("assistance_level")
    built = float(built) if isinstance(built, int | float) else None
    ran = None if built is None else assistance_in_effect(
        trial.arrays, trial.events, built, trial.sample_period_s, trial.summary)
    faults = [e["message"] for e in trial.events if e["kind"] == "fault"]
    columns = {**level_columns(str(values.get("assist", "thesis")), built, ran),
               **proposal_columns(None),
               "end_reason": "" if trial.status == "complete" else (faults[-1] if faults
                                                                    else "")}
    columns |= dict(source.outcome)
    return {name: columns[name] for name in OUTCOME_COLUMNS}



def _check_format(format: str, allowed: tuple[str, ...] = FORMATS) -> None:
    if format not in allowed:
        hint = " (a BIDS dataset is written by export_trials or export_patient)" if (
            format == "bids") else ""
        raise ExportError(f"export format {format!r}: give one of {', '.join(allowed)}{hint}")


def _outputs(format: str, folder: Path, stem: str) -> tuple[Path, ...]:
    if format == "mat":
        return (folder / f"{stem}.mat",)
    return table_outputs(folder, stem, f".{format}")


def _write(trial: Trial, format: str, folder: Path, stem: str, exercise_only: bool,
           digits: int | None, overwrite: bool, recorded: Mapping[str, float] | None = None,
           about: Mapping[str, str] | None = None) -> tuple[Path, ...]:
    """The trial's files; `recorded` is its file's own figures when `trial`'s are the
    registry's, `about` what the registry says of it (metrics_source, invalid_reason)."""
    if format == "mat":
        return (write_mat(trial, folder / f"{stem}.mat", exercise_only=exercise_only,
                          overwrite=overwrite, recorded=recorded, about=about),)
    return write_table(trial, folder, stem, suffix=f".{format}", exercise_only=exercise_only,
                       digits=digits, overwrite=overwrite, recorded=recorded, about=about)


def _refuse_duplicates(planned: Mapping[TrialSource, tuple[Path, ...]]) -> None:
    first: dict[Path, Path] = {}
    for source, paths in planned.items():
        if paths[0] in first:
            raise ExportError(
                f"{first[paths[0]]} and {source.path} would both be exported as "
                f"{paths[0]}. Nothing was written. Export them to different folders"
            )
        first[paths[0]] = source.path
