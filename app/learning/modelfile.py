"""A trained model's file: one JSON document with the model's spec and weights, what it
learned from, its hyper-parameters, its metrics, the software that trained it, and a
SHA-256 of all of it (docs/data-format.md, "Model files").

Plain JSON: float64 weights round-trip exactly (Python writes the shortest repr that reads
back the same number), any language reads it, and nothing is unpickled. A file is refused,
by the fault's name, when its content hash does not match (edited or damaged), when its
weights do not fit its input size, or when the data it is used on come from another system
or another number of coordinates.
"""

from __future__ import annotations

import hashlib
import json
import platform
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

import numpy as np

from app.errors import AppError
from core.learning import networks as nw

FORMAT = "rehab-console-model"
FORMAT_VERSION = 1


class ModelFileError(AppError):
    """A model file cannot be used; `reason` names the fault: `missing`, `format`,
    `content hash`, `input size`, `system`, and for control (app.learning.library) `kind`."""

    def __init__(self, path: object, reason: str, problem: str, advice: str) -> None:
        self.path, self.reason = path, reason
        super().__init__(f"model {path}: {reason}: {problem}. {advice}")


@dataclass(frozen=True)
class ModelFile:
    """A model read from its file, checked."""

    path: Path
    name: str
    spec: dict
    params: dict[str, np.ndarray]
    data: dict
    hyper_parameters: dict
    metrics: dict
    software: dict
    content_sha256: str

    @property
    def parameters(self) -> int:
        return nw.count_parameters(self.spec)

    def check_data(self, dataset) -> None:
        """Refuse data this model was not trained for: another system, another size."""
        if dataset.dof != self.spec["dof"]:
            raise ModelFileError(self.path, "input size",
                                 f"the model takes {self.spec['dof']} coordinates, "
                                 f"the data have {dataset.dof}",
                                 "Use a model trained on this system's data.")
        if dataset.system != self.data.get("system"):
            raise ModelFileError(self.path, "system",
                                 f"the model was trained on '{self.data.get('system')}', "
                                 f"the data are from '{dataset.system}'",
                                 "Use a model trained on this system's data.")


def software_versions() -> dict:
    versions = {"python": platform.python_version()}
    for package in ("rehab-console", "numpy", "jax", "jaxlib", "optax"):
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = "unknown"
    return versions


def content_hash(document: dict) -> str:
    """SHA-256 of the document without its hash, keys sorted, no spaces."""
    body = {k: v for k, v in document.items() if k != "content_sha256"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def write_model(path: str | Path, name: str, spec: dict, params: dict, data: dict,
                hyper_parameters: dict, metrics: dict, *, overwrite: bool = False,
                owned: bool = False) -> Path:
    """Write a trained model, whole or not at all; return its path. An existing file is
    replaced only with `overwrite`, never one a data folder owns unless `owned` (the
    console's own models/ folder: app.records.safewrite)."""
    from app.records.safewrite import OutputRefused, write_text

    path = Path(path)
    document = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "name": name,
        "created_utc": datetime.now(UTC).isoformat(),
        "model": spec,
        "weights": {k: {"shape": list(np.shape(v)),
                        "values": np.asarray(v, dtype=np.float64).reshape(-1).tolist()}
                    for k, v in sorted(params.items())},
        "parameters": nw.count_parameters(spec),
        "data": data, "hyper_parameters": hyper_parameters, "metrics": metrics,
        "software": software_versions(),
    }
    document["content_sha256"] = content_hash(document)
    try:
        write_text(path, json.dumps(document, indent=1, allow_nan=False) + "\n",
                   overwrite=overwrite, owned=owned)
    except (OSError, OutputRefused) as exc:
        raise ModelFileError(path, "format", f"cannot be written ({exc})",
                             "Choose another file, or a folder you can write to.") from None
    return path


def checked_document(path: Path, format_name: str, version: int, written_by: str,
                     again: str, noun: str = "a model file") -> dict:
    """A model file's JSON document, read and checked: there, JSON, of `format_name`, not
    of a newer version than `version`, its content matching its SHA-256. `written_by` is
    the command that writes such files, `again` what to do when the hash does not match,
    `noun` what such a file is called; ModelFileError otherwise."""
    if not path.is_file():
        raise ModelFileError(path, "missing", "no such file",
                             f"Check the path, or make one with `{written_by}`.")
    try:
        document = json.loads(path.read_text())
    except (ValueError, UnicodeDecodeError, OSError):
        raise ModelFileError(path, "format", "is not a JSON model file",
                             f"Give a file written by `{written_by}`.") from None
    if not isinstance(document, dict) or document.get("format") != format_name:
        raise ModelFileError(path, "format", f"is not {noun} of this console",
                             f"Give a file written by `{written_by}`.")
    if document.get("format_version", 0) > version:
        raise ModelFileError(path, "format", f"is format version "
                             f"{document.get('format_version')}, newer than this console's "
                             f"{version}", "Update the console.")
    if document.get("content_sha256") != content_hash(document):
        raise ModelFileError(path, "content hash", "the file's content does not match its "
                             "SHA-256 (edited or damaged)", again)
    return document


def read_model(path: str | Path) -> ModelFile:
    """Read and check a model file."""
    path = Path(path)
    document = checked_document(path, FORMAT, FORMAT_VERSION, "rehab learn train",
                                "Train the model again or restore the file from its copy.")
    try:
        spec = document["model"]
        expected = nw.param_shapes(spec)
        weights = document["weights"]
        params = {k: np.asarray(w["values"], dtype=np.float64).reshape(w["shape"])
                  for k, w in weights.items()}
    except (KeyError, TypeError, ValueError) as exc:
        raise ModelFileError(path, "format", f"its model or weights are incomplete ({exc})",
                             "Train the model again.") from None
    wrong = sorted(k for k in expected.keys() | params.keys()
                   if k not in params or k not in expected
                   or tuple(params[k].shape) != tuple(expected[k]))
    if wrong:
        raise ModelFileError(path, "input size", f"weights {', '.join(wrong)} do not fit "
                             f"the model's {spec.get('dof')} coordinates and its layers",
                             "Train the model again.")
    return ModelFile(path=path, name=str(document.get("name", path.stem)), spec=spec,
                     params=params, data=document.get("data", {}),
                     hyper_parameters=document.get("hyper_parameters", {}),
                     metrics=document.get("metrics", {}),
                     software=document.get("software", {}),
                     content_sha256=document["content_sha256"])
