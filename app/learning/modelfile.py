"""A trained model's file: one JSON document with the model's spec and weights, what it
learned from, its hyper-parameters, its metrics, the software that trained it, and a
SHA-256 of all of it (docs/data-format.md, "Model files").

Plain JSON: float64 weights round-trip exactly (Python writes the shortest repr that reads
back the same number), any language reads it, and nothing is unpickled. A file is refused,
by the fault's name, when its content hash does not match (damaged), when it does not carry
this installation's signature (`signature`: edited and rehashed, or brought from elsewhere
without `rehab models import`; app.records.signing), when its weights do not fit its input
size or are not finite numbers a trained model has (`weights`), or when the data it is
used on come from another system or another number of coordinates.
"""

from __future__ import annotations

import hashlib
import json
import math
import platform
from dataclasses import dataclass
from datetime import UTC, datetime
from importlib import metadata
from pathlib import Path

import numpy as np

from app.errors import AppError
from app.records import signing
from core.learning import networks as nw

FORMAT = "rehab-console-model"
FORMAT_VERSION = 1
MAX_WEIGHT = 1e12
"""The largest magnitude a weight or normalisation constant may have. A trained model's
are far smaller (Adam from a small start, inputs and outputs standardised); one of 1e308
made every torque overflow to inf and `rehab learn evaluate` printed RMSE inf. Products
through a few layers of 1e12 stay finite."""
MAX_BYTES = 64 * 2**20
"""A model file larger than this is not one the console wrote (the largest, a DeLaN of
a few thousand weights, is well under 1 MiB)."""


class ModelFileError(AppError):
    """A model file cannot be used; `reason` names the fault: `missing`, `format`,
    `content hash`, `signature`, `weights`, `input size`, `system`, and for control
    (app.learning.library) `kind`."""

    def __init__(self, path: object, reason: str, problem: str, advice: str) -> None:
        self.path, self.reason, self.problem = path, reason, problem
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
    """SHA-256 of the document without its hash and its signature, keys sorted, no
    spaces."""
    body = {k: v for k, v in document.items() if k not in ("content_sha256", "signature")}
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
    document = signing.sign(document)
    try:
        write_text(path, json.dumps(document, indent=1, allow_nan=False) + "\n",
                   overwrite=overwrite, owned=owned)
    except (OSError, OutputRefused) as exc:
        raise ModelFileError(path, "format", f"cannot be written ({exc})",
                             "Choose another file, or a folder you can write to.") from None
    return path


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


def load_document(path: Path, written_by: str) -> dict:
    """A JSON object from `path`: bounded in size, no NaN or Infinity, no nesting deeper
    than Python's recursion allows; ModelFileError `format` otherwise."""
    try:
        if path.stat().st_size > MAX_BYTES:
            raise ValueError("too large")
        document = json.loads(path.read_bytes().decode("utf-8"),
                              parse_constant=_no_constant)
    except (ValueError, UnicodeDecodeError, OSError, RecursionError):
        raise ModelFileError(path, "format", "is not a JSON model file",
                             f"Give a file written by `{written_by}`.") from None
    return document


def checked_document(path: Path, format_name: str, version: int, written_by: str,
                     again: str, noun: str = "a model file", signed: bool = True) -> dict:
    """A model file's JSON document, read and checked: there, JSON, of `format_name`, not
    of a newer version than `version`, its content matching its SHA-256 and, unless
    `signed` is False (`rehab models import`, which signs it), signed by this installation
    (app.records.signing). `written_by` is the command that writes such files, `again`
    what to do when the hash does not match, `noun` what such a file is called;
    ModelFileError otherwise."""
    if not path.is_file():
        raise ModelFileError(path, "missing", "no such file",
                             f"Check the path, or make one with `{written_by}`.")
    document = load_document(path, written_by)
    if not isinstance(document, dict) or document.get("format") != format_name:
        raise ModelFileError(path, "format", f"is not {noun} of this console",
                             f"Give a file written by `{written_by}`.")
    stated = document.get("format_version")
    if isinstance(stated, bool) or not isinstance(stated, int) or stated < 1:
        raise ModelFileError(path, "format", f"has format_version {str(stated)[:20]!r}, not "
                             "a whole number", f"Give a file written by `{written_by}`.")
    if stated > version:
        raise ModelFileError(path, "format", f"is format version {stated}, newer than this "
                             f"console's {version}", "Update the console.")
    if document.get("content_sha256") != content_hash(document):
        raise ModelFileError(path, "content hash", "the file's content does not match its "
                             "SHA-256 (edited or damaged)", again)
    if signed:
        problem = signing.signature_problem(document)
        if problem:
            raise ModelFileError(path, "signature", problem,
                                 "Bring a model from elsewhere in with `rehab models import "
                                 f"FILE` (it is checked, then signed here); {again[:1].lower()}"
                                 f"{again[1:]}")
    return document


def check_numbers(path: Path, what: str, values) -> None:
    """Every number in `values` (nested lists, dicts) finite and within MAX_WEIGHT;
    ModelFileError `weights` otherwise."""
    stack = [values]
    while stack:
        item = stack.pop()
        if isinstance(item, dict):
            stack.extend(item.values())
        elif isinstance(item, list):
            stack.extend(item)
        elif isinstance(item, float | int) and not isinstance(item, bool) and not (
                math.isfinite(item) and abs(item) <= MAX_WEIGHT):
            raise ModelFileError(path, "weights", f"its {what} hold {item!r}, not the finite "
                                 f"numbers (at most {MAX_WEIGHT:g} in size) a trained model "
                                 "has", "Train the model again or restore the file.")


def read_model(path: str | Path, *, signed: bool = True) -> ModelFile:
    """Read and check a model file (`signed=False`: all but this installation's signature,
    for `rehab models import`). The model is named by its file's stem: a copy under a new
    name is that model under that name (its content, hash and signature unchanged)."""
    path = Path(path)
    document = checked_document(path, FORMAT, FORMAT_VERSION, "rehab learn train",
                                "Train the model again or restore the file from its copy.",
                                signed=signed)
    check_numbers(path, "weights", document.get("weights"))
    check_numbers(path, "normalisation", document.get("model"))
    try:
        spec = document["model"]
        expected = nw.param_shapes(spec)
        weights = document["weights"]
        params = {k: np.asarray(w["values"], dtype=np.float64).reshape(w["shape"])
                  for k, w in weights.items()}
    except (KeyError, TypeError, ValueError, AttributeError) as exc:
        raise ModelFileError(path, "format", f"its model or weights are incomplete ({exc})",
                             "Train the model again.") from None
    wrong = sorted(k for k in expected.keys() | params.keys()
                   if k not in params or k not in expected
                   or tuple(params[k].shape) != tuple(expected[k]))
    if wrong:
        raise ModelFileError(path, "input size", f"weights {', '.join(wrong)} do not fit "
                             f"the model's {spec.get('dof')} coordinates and its layers",
                             "Train the model again.")
    return ModelFile(path=path, name=path.stem, spec=spec,
                     params=params, data=document.get("data", {}),
                     hyper_parameters=document.get("hyper_parameters", {}),
                     metrics=document.get("metrics", {}),
                     software=document.get("software", {}),
                     content_sha256=document["content_sha256"])
