"""Export to a BIDS dataset with the motion extension (BIDS 1.9.0).

Layout (one run per trial)::

    dataset_description.json  README  participants.tsv  participants.json
    sub-<code>/ses-<session>/motion/
        sub-<code>_ses-<session>_task-<task>_tracksys-<backend>_run-<trial>_motion.tsv
        …_motion.json  …_channels.tsv  …_channels.json  …_events.tsv  …_events.json

* `<code>` is the registry's pseudonymous patient code (any character other than a
  letter or digit removed, as BIDS labels require); `<session>` and `<trial>` the
  registry's numbers; `<task>` an assessment's task (reaching, circle, range, strength,
  position), else the exercise's shape (d, circle, reach, targets, figure8);
  `<backend>` the robot backend (simulator, quanser), so simulated and measured
  data never share a name.
* ``_motion.tsv``: no header, as BIDS requires; one column per row of
  ``_channels.tsv`` (every component of every channel of the trial file, named as
  in the CSV export), one line per sample; values exact (app.exports.columns),
  missing values ``n/a``.
* ``_channels.tsv``: name, component, type, tracked_point, units (the REQUIRED
  columns, in that order), then sampling_frequency, reference_frame, description.
* ``_motion.json``: TaskName, SamplingFrequency (REQUIRED), and TaskDescription,
  SamplingFrequencyEffective (from wall_time), TrackingSystemName, Manufacturer
  ("Quanser"), ManufacturersModelName, SoftwareVersions, RecordingType,
  RecordingDuration, MotionChannelCount, TrackedPointsCount, a <TYPE>ChannelCount
  per channel type, MissingValues (no custom keys: the legacy validator refuses them).
* ``sub-<code>_ses-<session>_scans.tsv``: one row per run, its trial's status and
  parameters, and why the registry marks it invalid (app.exports.bids_scans).
* ``wall_time`` (LATENCY) counts from the run's first sample (the trial file's counts
  from the robot's Connect).
* ``participants.tsv``: participant_id and only non-identifying columns:
  body_mass_kg, upper_arm_m, forearm_m, side (from the participant's latest
  trial), described in participants.json. Names only with an explicit
  `names` mapping (first_name, last_name columns), never in any other file.

Exporting into a folder that already holds a dataset adds to it: participants.tsv
keeps the rows of other participants, and dataset_description.json, README and
the run files of other trials are left alone. Run files that exist are refused
unless `overwrite`.

Where this deviates from BIDS 1.9.0 (and why):

* Entity order is the specification's (task, tracksys, run), so run comes
  after tracksys, not before it.
* Channel types and units: see app.exports.bids_channels (angles in rad, force
  and torque as MISC, CMIXF units).
* participants.tsv has neither age nor sex (the trial files do not hold them;
  age would also identify), and custom columns body_mass_kg, upper_arm_m,
  forearm_m, side.
* ``*_scans.tsv`` without acq_time: it would carry the dates of the recordings.
* EMG is not exported: BIDS 1.9 has no EMG datatype (the CSV and .mat exports hold it);
  the result's notes say which trials had it.
* dataset_description.json has no License or Authors (RECOMMENDED): add them
  before sharing the dataset.
* Trial files not named by the console (no session or trial number in the name)
  go in ses-1 and are numbered by their creation time.
"""

from __future__ import annotations

import json
import logging
import math
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import AppError
from app.exports.bids_channels import CHANNEL_TYPES, FRAMES, BidsChannel, bids_channels
from app.exports.bids_scans import rows_by, scan_row, scans_path, write_scans
from app.exports.files import ExportError, output, prepare_folder, refuse_existing, write_text
from app.exports.loader import Failure
from app.exports.plan import ExportResult, TrialSource, one_trial
from app.exports.table import write_samples
from app.exports.trialinfo import Trial, TrialInfo, load_trial, read_info
from core.assessment.protocol import PROTOCOLS
from device.recording.emgfile import read_emg
from device.recording.trialfile import software_version

log = logging.getLogger(__name__)

BIDS_VERSION = "1.9.0"
MANUFACTURER = "Quanser"
MODEL_NAME = "planar 2-DOF parallelogram end-effector upper-limb rehabilitation robot"
DEFAULT_DATASET_NAME = "Upper-limb rehabilitation robot trials"
RUN_FILES = ("motion.tsv", "motion.json", "channels.tsv", "channels.json", "events.tsv",
             "events.json")
PARTICIPANT_COLUMNS = ("participant_id", "body_mass_kg", "upper_arm_m", "forearm_m", "side")
NAME_COLUMNS = ("first_name", "last_name")

_NOT_LABEL = re.compile(r"[^A-Za-z0-9]")
_TSV_BREAKS = re.compile(r"[\t\r\n]")
_PATHS = {"d": "a D-shaped path", "circle": "a circle", "reach": "a straight reach",
          "targets": "centre-out reaches to targets", "figure8": "a figure of eight"}
_EVENT_KINDS = {
    "start": "the trial started",
    "stop": "the trial ended",
    "fault": "a safety fault stopped the robot (message and values say which)",
    "mark": "a mark set by the therapist",
    "note": "a note entered during the trial",
    "assistance": "the therapist changed the assistance level (values: level, from this tick)",
    "patient_screen": "what the patient's screen showed from this tick (values: open and its "
                      "options)",
    "recording": "the recorder about the file itself (values: cause)",
}

Progress = Callable[[float], None]


@dataclass(frozen=True, slots=True)
class _Run:
    source: TrialSource
    info: TrialInfo
    participant: str
    session: int
    task: str
    tracksys: str
    run: int

    @property
    def key(self) -> tuple:
        return (self.participant, self.session, self.task, self.tracksys, self.run)

    @property
    def prefix(self) -> str:
        return (f"sub-{self.participant}_ses-{self.session}_task-{self.task}"
                f"_tracksys-{self.tracksys}_run-{self.run}")

    def paths(self, root: Path) -> dict[str, Path]:
        folder = root / f"sub-{self.participant}" / f"ses-{self.session}" / "motion"
        return {suffix: folder / f"{self.prefix}_{suffix}" for suffix in RUN_FILES}


def bids_label(text: str) -> str:
    """A BIDS label: letters and digits only."""
    return _NOT_LABEL.sub("", text)


def export_bids(
    sources: Iterable[TrialSource],
    folder: str | Path,
    *,
    names: Mapping[str, tuple[str | None, str | None]] | None = None,
    dataset_name: str = DEFAULT_DATASET_NAME,
    overwrite: bool = False,
    progress: Progress | None = None,
) -> ExportResult:
    """Write the trials as runs of a BIDS dataset in `folder` (see the module's doc).

    `names` maps participant codes to (first name, last name) and adds those two
    columns to participants.tsv; give it only when the dataset may hold names.
    Unreadable trial files are skipped and listed in the result's `failed`.
    """
    root = prepare_folder(folder)
    failed: list[Failure] = []
    runs = _plan(list(sources), failed)
    targets = [path for run in runs for path in run.paths(root).values()]
    refuse_existing(targets, overwrite)

    written: list[Path] = []
    exported: list[_Run] = []
    scans: dict = {}
    if progress is not None:
        progress(0.0)
    for i, run in enumerate(runs):
        paths = run.paths(root)
        files = one_trial(run.source.path,
                          lambda run=run, paths=paths: _write_run(load_trial(run.source.path),
                                                                  run, paths, overwrite, scans),
                          failed, paths.values())
        if files is not None:
            written += files
            exported.append(run)
        if progress is not None:
            progress((i + 1) / len(runs))

    with_emg = scans.pop("emg", [])
    for (participant, session), rows in sorted(scans.items()):
        written += write_scans(scans_path(root, participant, session), rows, _write_tsv,
                               _write_json)
    written += _write_dataset_files(root, exported, names or {}, dataset_name, overwrite)
    log.info("BIDS export to %s: %d trial(s), %d file(s) written, %d trial(s) unreadable",
             root, len(exported), len(written), len(failed))
    notes = (f"EMG not exported for {len(with_emg)} run(s) ({', '.join(with_emg[:3])}"
             f"{', …' if len(with_emg) > 3 else ''}): BIDS 1.9 has no EMG datatype; the CSV "
             "and .mat exports hold it",) if with_emg else ()
    return ExportResult(root, tuple(written), len(exported), tuple(failed), notes)


# -- planning ------------------------------------------------------------------


def _plan(sources: list[TrialSource], failed: list[Failure]) -> list[_Run]:
    """Labels and numbers for every readable source; refuses two trials on one name."""
    known: list[_Run] = []
    unnumbered: list[_Run] = []
    for source in sources:
        try:
            info = read_info(source.path)
        except AppError as exc:
            failed.append(Failure(source.path, str(exc)))
            continue
        code = source.participant or (info.subject.code if info.subject else "")
        participant = bids_label(code)
        if not participant:
            failed.append(Failure(source.path, "the trial file names no subject code, so it "
                                  "has no BIDS participant; export it from the registry"))
            continue
        run = _Run(source, info, participant, source.session or 1,
                   bids_label(task_of(info.parameter_values)) or "unknown",
                   bids_label(info.backend.split(" ", 1)[0]) or "robot", source.run or 0)
        (known if source.run else unnumbered).append(run)

    taken = {run.key for run in known}
    for run in sorted(unnumbered, key=lambda r: (r.info.created_utc, str(r.source.path))):
        number = 1
        while (*run.key[:4], number) in taken:
            number += 1
        numbered = _Run(run.source, run.info, run.participant, run.session, run.task,
                        run.tracksys, number)
        taken.add(numbered.key)
        known.append(numbered)

    seen: dict[tuple, Path] = {}
    for run in known:
        if run.key in seen:
            raise ExportError(
                f"two trials would both be {run.prefix}: {seen[run.key]} and "
                f"{run.source.path}. Nothing was written. Export them separately, or "
                "remove the duplicate file"
            )
        seen[run.key] = run.source.path
    return sorted(known, key=lambda r: r.key)


# -- one run -------------------------------------------------------------------


def _write_run(trial: Trial, run: _Run, paths: dict[str, Path], overwrite: bool,
               scans: dict) -> list[Path]:
    channels = bids_channels(trial)
    arrays = dict(trial.arrays)
    if "wall_time" in arrays and len(arrays["wall_time"]):
        # LATENCY from the run's onset: the file's wall_time counts from Connect
        arrays["wall_time"] = arrays["wall_time"] - arrays["wall_time"][0]
    with output(paths["motion.tsv"], overwrite=overwrite, text=True) as stream:
        write_samples(stream, arrays, [c.column for c in channels], "\t", missing="n/a")
    scans.setdefault((run.participant, run.session), []).append(
        scan_row(paths["motion.tsv"], trial.status, trial.parameter_values,
                 run.source.invalid_reason))
    if read_emg(trial.path) is not None:
        scans.setdefault("emg", []).append(run.prefix)
    _write_tsv(paths["channels.tsv"], overwrite,
               ("name", "component", "type", "tracked_point", "units", "sampling_frequency",
                "reference_frame", "description"),
               [(c.name, c.component, c.type, c.tracked_point, c.units,
                 _number(_hz(trial.sampling_frequency_hz)), c.reference_frame, c.description)
                for c in channels])
    _write_json(paths["motion.json"], _motion_sidecar(trial, run, channels), overwrite)
    frames = sorted({c.reference_frame for c in channels} - {"n/a"})
    _write_json(paths["channels.json"], {
        "reference_frame": {
            "Description": "the frame the channel's numbers are expressed in "
                           "(docs/data-format.md of the console)",
            "Levels": {frame: FRAMES[frame] for frame in frames},
        },
        "sampling_frequency": {"Description": "sampling rate of the channel", "Units": "Hz"},
        "description": {"Description": "what the channel is, as the trial file says"},
    }, overwrite)
    start_s = float(trial.time[0]) if trial.n_samples and "time" in trial else 0.0
    _write_tsv(paths["events.tsv"], overwrite,
               ("onset", "duration", "trial_type", "tick", "message", "values"),
               [(_number(e["time_s"] - start_s), "0", e["kind"], e["tick"], e["message"] or "n/a",
                 json.dumps(e["values"], ensure_ascii=False))
                for e in sorted(trial.events, key=lambda e: e["time_s"])])
    kinds = sorted({e["kind"] for e in trial.events})
    _write_json(paths["events.json"], {
        "trial_type": {"Description": "kind of event",
                       "Levels": {k: _EVENT_KINDS.get(k, k) for k in kinds}},
        "tick": {"Description": "loop tick (2 ms at 500 Hz) at which the event happened"},
        "message": {"Description": "the event as the console showed it"},
        "values": {"Description": "the event's numbers, a JSON object"},
    }, overwrite)
    return list(paths.values())


def _motion_sidecar(trial: Trial, run: _Run, channels: Sequence[BidsChannel]) -> dict:
    types = [c.type for c in channels]
    sidecar = {
        "TaskName": run.task,
        "TaskDescription": _task_description(trial.parameter_values),
        "SamplingFrequency": _hz(trial.sampling_frequency_hz),
        "SamplingFrequencyEffective": _effective_hz(trial),
        "TrackingSystemName": f"rehabilitation robot, {trial.backend or 'unknown backend'}",
        "Manufacturer": MANUFACTURER,
        "ManufacturersModelName": MODEL_NAME,
        "SoftwareVersions": f"rehab-console {trial.software_version}",
        "RecordingType": "continuous",
        "RecordingDuration": trial.recorded_s,
        "MotionChannelCount": len(channels),
        "TrackedPointsCount": len({c.tracked_point for c in channels}),
    }
    sidecar |= {f"{kind}ChannelCount": types.count(kind) for kind in CHANNEL_TYPES}
    sidecar |= {
        "MissingValues": "n/a",
    }
    return sidecar


def task_of(values: Mapping) -> str:
    """A run's task: an assessment's task (reaching, circle, range, strength, position),
    else the exercise's shape; an assessment's shape alone would give the reaching, range
    and position tasks one name, and the strength test (the handle held still) the name
    of reaches."""
    assessment = values.get("assessment")
    if isinstance(assessment, str) and assessment:
        return assessment
    shape = values.get("shape")
    return shape if isinstance(shape, str) else ""


def _task_description(values: Mapping) -> str:
    """The run's task in words: the console's label of its exercise (the mode, the shape,
    the controller: app.reports.progress.exercise_of, as Progress and a study name it),
    then an assessment's protocol, or the path the handle was guided along."""
    from app.reports.progress import exercise_of

    label = exercise_of(str(values.get("assist", "thesis")), values).label()
    assessment = values.get("assessment")
    if isinstance(assessment, str) and assessment in PROTOCOLS:
        return f"{label}. {PROTOCOLS[assessment].therapist}"
    shape = values.get("shape", "?")
    text = f"{label}: the handle along {_PATHS.get(shape, f'a {shape} path')}"
    if "radius_m" in values and "repetitions" in values and "duration_s" in values:
        text += (f" (radius {values['radius_m']:.3f} m, {values['repetitions']} × "
                 f"{values['duration_s']:g} s")
        if "clockwise" in values:
            text += ", clockwise" if values["clockwise"] else ", counter-clockwise"
        text += ")"
    if "assistance_level" in values:
        text += f", assistance level {values['assistance_level']} at the start"
    return text


def _effective_hz(trial: Trial) -> float | str:
    if "wall_time" not in trial or trial.n_samples < 2:
        return "n/a"
    wall = trial["wall_time"]
    span = float(wall[-1] - wall[0])
    if not math.isfinite(span) or span <= 0:
        return "n/a"
    return (trial.n_samples - 1) / span


def _hz(value: float) -> float:
    # 1 / 0.002 is 499.99999999999994 in binary; the nominal rate is 500.
    return round(value, 9)


# -- dataset files -------------------------------------------------------------


def _write_dataset_files(root: Path, runs: list[_Run], names: Mapping, dataset_name: str,
                         overwrite: bool) -> list[Path]:
    written = []
    description = root / "dataset_description.json"
    if overwrite or not description.exists():
        written.append(_write_json(description, {
            "Name": dataset_name,
            "BIDSVersion": BIDS_VERSION,
            "DatasetType": "raw",
            "GeneratedBy": [{
                "Name": "rehab-console",
                "Version": software_version(),
                "Description": "export of the console's HDF5 trial files (app.exports.bids)",
            }],
        }, overwrite=True))
    readme = root / "README.md"
    if overwrite or not readme.exists():
        written.append(write_text(readme, _README, overwrite=True))
    if runs or (root / "participants.tsv").exists():
        written += _write_participants(root, runs, names)
    return written


def _write_participants(root: Path, runs: list[_Run], names: Mapping) -> list[Path]:
    path = root / "participants.tsv"
    rows = rows_by(path, "participant_id")
    latest: dict[str, _Run] = {}
    for run in sorted(runs, key=lambda r: r.info.created_utc):
        latest[run.participant] = run
    code_of = {bids_label(code): code for code in names}
    for label, run in latest.items():
        subject = run.info.subject
        row = {"participant_id": f"sub-{label}"}
        if subject is not None:
            row |= {"body_mass_kg": _number(subject.body_mass_kg),
                    "upper_arm_m": _number(subject.upper_arm_m),
                    "forearm_m": _number(subject.forearm_m), "side": subject.side}
        if label in code_of:
            first, last = names[code_of[label]]
            row |= {"first_name": first or "n/a", "last_name": last or "n/a"}
        rows[row["participant_id"]] = row
    columns = list(PARTICIPANT_COLUMNS)
    for row in rows.values():
        columns += [key for key in row if key not in columns]
    _write_tsv(path, True, tuple(columns),
               [tuple(row.get(c) or "n/a" for c in columns)
                for _, row in sorted(rows.items())])
    described = {
        "participant_id": {"Description": "the registry's pseudonymous patient code; only "
                                          "the clinic's registry links it to a person"},
        "body_mass_kg": {"Description": "body mass used by the arm model", "Units": "kg"},
        "upper_arm_m": {"Description": "shoulder to elbow length", "Units": "m"},
        "forearm_m": {"Description": "elbow to wrist length", "Units": "m"},
        "side": {"Description": "arm used in the trials",
                 "Levels": {"right": "right arm", "left": "left arm"}},
        "first_name": {"Description": "first name: IDENTIFYING, exported on request only"},
        "last_name": {"Description": "last name: IDENTIFYING, exported on request only"},
    }
    sidecar = {c: described.get(c, {"Description": c}) for c in columns}
    return [path, _write_json(root / "participants.json", sidecar, overwrite=True)]


def _write_tsv(path: Path, overwrite: bool, header: tuple, rows: Iterable) -> Path:
    # BIDS TSV is plain: no CSV quoting (the validator reads quotes as text), so
    # tabs and line breaks inside a value become spaces instead.
    with output(path, overwrite=overwrite, text=True) as stream:
        for row in (header, *rows):
            stream.write("\t".join(_TSV_BREAKS.sub(" ", str(value)) for value in row) + "\n")
    return path


def _write_json(path: Path, values: dict, overwrite: bool) -> Path:
    return write_text(path, json.dumps(values, indent=2, ensure_ascii=False, allow_nan=False)
                      + "\n", overwrite=overwrite)


def _number(value: float) -> str:
    return "n/a" if not np.isfinite(value) else repr(float(value))


_README = """\
# Upper-limb rehabilitation robot trials

Trials recorded with the rehab-console on a planar 2-DOF end-effector rehabilitation
robot (or its simulator: see `tracksys`), exported from the console's HDF5 trial
files in the BIDS motion format (BIDS 1.9.0).

* One run per trial: `sub-<code>/ses-<session>/motion/…_run-<trial>_motion.tsv`, one
  column per row of the `_channels.tsv` beside it, one line per sample.
* Units are SI (m, s, rad, N, N.m); angles are in rad. Frames are described in each
  `_channels.json` (`reference_frame`).
* Participants are identified by pseudonymous codes only; `participants.tsv` holds body
  mass, segment lengths and the arm used.
* Each session's `_scans.tsv` holds every run's trial parameters (`trial_parameters`) and
  how it ended (`trial_status`); `_events.tsv` its start, stop and safety faults.
* `wall_time` counts from the run's first sample.

Fill in `License` and `Authors` in `dataset_description.json` before sharing.
"""
