"""The sessions' `*_scans.tsv` of a BIDS export: one row per run with how the trial ended,
the parameters it ran with and why the registry marks it invalid (a run exported with
--include-invalid would otherwise read as any other).

BIDS puts what belongs to one recording file and is not a channel or an event in the
session's scans file (BIDS 1.9, "Scans file": `filename` REQUIRED, other columns
described in `*_scans.json`). These two were custom keys of `_motion.json` before, which the
legacy validator (bids-validator 1.15) refuses for every run ("should NOT have additional
properties", code 55); a scans file is where both validators accept them. There is no
`acq_time`: it would carry the dates of the recordings.

Adding runs to an existing dataset keeps the rows of the runs already there.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable, Mapping
from pathlib import Path

COLUMNS = ("filename", "trial_status", "trial_parameters", "invalid_reason")
SIDECAR = {
    "trial_status": {
        "Description": "how the trial ended, as its file says",
        "Levels": {"complete": "ran to its end", "stopped_early": "stopped by the therapist",
                   "faulted": "stopped by a safety fault (see the run's events)",
                   "recording_lost": "the recording failed; the motors were stopped"},
    },
    "trial_parameters": {
        "Description": "the trial's parameters as a JSON object, SI units, the names of the "
                       "console's trial files (docs/data-format.md)",
    },
    "invalid_reason": {
        "Description": "why the console's registry marks the trial invalid (a run exported "
                       "with --include-invalid); n/a when it does not, or no registry knew "
                       "the trial",
    },
}


def scans_path(root: Path, participant: str, session: int) -> Path:
    return (root / f"sub-{participant}" / f"ses-{session}"
            / f"sub-{participant}_ses-{session}_scans.tsv")


def scan_row(motion_tsv: Path, status: str, parameters: Mapping,
             invalid_reason: str | None = None) -> dict[str, str]:
    """A run's row: its motion file relative to the session's folder."""
    return {"filename": f"{motion_tsv.parent.name}/{motion_tsv.name}",
            "trial_status": status or "n/a",
            "trial_parameters": json.dumps(dict(parameters), ensure_ascii=False,
                                           allow_nan=False, default=str),
            "invalid_reason": _one_line(invalid_reason) or "n/a"}


def _one_line(text: str | None) -> str:
    """A reason as one TSV cell: no tab or line break (a therapist's reason may hold them)."""
    return " ".join((text or "").split())


def rows_by(path: Path, key: str) -> dict[str, dict]:
    """The rows of a dataset's TSV file already there, by their `key` column (none when
    the file is not there): an export that adds runs keeps the others'."""
    rows: dict[str, dict] = {}
    if path.exists():
        with path.open(encoding="utf-8", newline="") as stream:
            for row in csv.DictReader(stream, delimiter="\t", quoting=csv.QUOTE_NONE):
                if row.get(key):
                    rows[row[key]] = row
    return rows


def write_scans(path: Path, rows: list[dict[str, str]],
                write_tsv: Callable, write_json: Callable) -> list[Path]:
    """Write the session's scans file with `rows` added to (or replacing by filename) the
    rows it has, and its sidecar."""
    merged = rows_by(path, "filename")
    for row in rows:
        merged[row["filename"]] = row
    table = [tuple(row.get(c) or "n/a" for c in COLUMNS) for _, row in sorted(merged.items())]
    return [write_tsv(path, True, COLUMNS, table),
            write_json(path.with_suffix(".json"), SIDECAR, True)]
