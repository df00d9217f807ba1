"""An EMG-to-torque model approved to estimate the patient's force for the assistance (the
thesis's cHRI aim, section 5): one JSON file in the data folder's models/emg/, written only
for a model that passed every held-out validation (app.emg.validation.approve), with those
validations, the muscles it takes, the EMG processing it was trained with and a SHA-256
of all of it (docs/data-format.md, "EMG model files").

A file is refused, by the fault's name (ModelFileError.reason, as for the learned robot
models), when it is missing, is not an EMG model file (`format`), does not match its
hash (`content hash`), does not carry this installation's signature (`signature`: the
approval cannot be re-signed by editing, app.records.signing), takes other muscles than
the session has (`muscles`), or does not show a passing validation under the console's
rule (`not approved`: a file cannot make a failed model usable by being written by hand).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from app.emg.validation import ModelNotApproved, approve
from app.learning.modelfile import (
    ModelFileError,
    check_numbers,
    checked_document,
    content_hash,
    software_versions,
)
from app.records import signing
from app.records.safewrite import OutputRefused, write_text
from core.emg.force import USABLE_CONE_AGREEMENT
from core.emg.models import USABLE_R2, Validation, inputs_of, model_from_dict
from core.emg.processing import EmgSettings
from core.errors import ParameterError
from core.trial import MODEL_NAME
from device.safewrite import make_private_folders

FORMAT = "rehab-console-emg-model"
FORMAT_VERSION = 1
FOLDER = "emg"
"""The EMG models' folder inside the data folder's models/."""
SUFFIX = ".json"


@dataclass(frozen=True)
class EmgModelFile:
    """An approved EMG-to-torque model read from its file, checked."""

    path: Path
    name: str
    model: object
    muscles: tuple[str, ...]
    settings: EmgSettings
    validations: tuple[Validation, ...]
    trials: tuple[str, ...]
    dt_s: float
    """The time step of the envelopes it was trained on (s): it is fed on the same."""
    as_live: bool
    """Trained on the envelopes a live console has at each tick (their windows ending
    there), as it is fed them."""
    latency_s: float
    """How late the EMG source was taken to deliver each sample when its force was
    validated (s): a source later than that was not shown to do."""
    content_sha256: str

    @property
    def tolerance_rad(self) -> float:
        """The narrowest cone its held-out force was shown to judge as the sensor does."""
        return max(v.force.tolerance_rad for v in self.validations)

    def refusal(self, parameters, source_latency_s: float) -> str:
        """Why a trial may not judge the patient's force by this model ("" if it may): a
        cone narrower than the one it was validated with, or an EMG source later than the
        one its validation replayed."""
        if source_latency_s > self.latency_s + 1e-9:
            return (f"EMG model {self.name} was validated with EMG arriving "
                    f"{1e3 * self.latency_s:.0f} ms late; this source's arrives "
                    f"{1e3 * source_latency_s:.0f} ms late, so the estimate would be older "
                    "than shown to work. Validate it again with --latency, or use the "
                    "force sensor")
        if parameters.tolerance_rad < self.tolerance_rad - 1e-9:
            return (f"EMG model {self.name} was validated with a "
                    f"{math.degrees(self.tolerance_rad):.0f}° tolerance cone; this trial's "
                    f"is {math.degrees(parameters.tolerance_rad):.0f}°, narrower than the "
                    "estimate was shown to judge. Widen the tolerance, or use the force "
                    "sensor")
        return ""

    @property
    def summary(self) -> str:
        """One line: the model and its weakest held-out R²."""
        worst = min(min(v.score.r2) for v in self.validations)
        return (f"{self.name} ({self.model.name} on {', '.join(self.muscles)}; held-out R² "
                f"≥ {worst:.2f} in {len(self.validations)} validation"
                f"{'s' if len(self.validations) > 1 else ''})")


def models_folder(models_dir: str | Path) -> Path:
    return Path(models_dir) / FOLDER


def model_path(models_dir: str | Path, name: str) -> Path:
    return models_folder(models_dir) / f"{name}{SUFFIX}"


def refuse_taken(models_dir: str | Path, name: str) -> Path:
    """The path a model named `name` is saved at; ModelFileError when a model holds it
    already (a saved model is never replaced)."""
    path = model_path(models_dir, name)
    if path.exists():
        raise ModelFileError(path, "format", "already exists",
                             "Give another name; the saved model is kept as it is.")
    return path


def save_approved(models_dir: str | Path, name: str, checked) -> Path:
    """Write the checked model (app.emg.validation.CheckedModel) as `name` in models/emg/
    if every held-out validation passed (ModelNotApproved, writing nothing, otherwise);
    an existing file is never replaced."""
    model, validations = checked.model, checked.validations
    if not MODEL_NAME.fullmatch(name):
        raise ModelFileError(name, "format", "is not a model name",
                             "Use letters, digits, . _ - (at most 100).")
    approve(model, validations)
    path = refuse_taken(models_dir, name)
    document = {
        "format": FORMAT, "format_version": FORMAT_VERSION, "name": name,
        "created_utc": datetime.now(UTC).isoformat(),
        "model": model.to_dict(), "muscles": list(checked.muscles),
        "settings": checked.settings.to_dict(), "dt_s": float(checked.dt_s),
        "as_live": bool(checked.as_live), "latency_s": float(checked.latency_s),
        "validations": [v.to_dict() for v in validations],
        "trials": [str(t) for t in checked.trials],
        "software": software_versions(),
    }
    document["content_sha256"] = content_hash(document)
    document = signing.sign(document)
    try:
        make_private_folders(path.parent)
        # whole or not at all, never over a file written meanwhile, 0600 (app.records.safewrite)
        write_text(path, json.dumps(document, indent=1, allow_nan=False) + "\n", owned=True)
    except OutputRefused as exc:
        raise ModelFileError(path, "format", f"cannot be written ({exc})",
                             "Choose a data folder you can write to, with space.") from None
    return path


def read_emg_model(path: str | Path, muscles=None, *, signed: bool = True) -> EmgModelFile:
    """Read and check an EMG model file; with `muscles`, refuse a model that takes others
    (`signed=False`: all but this installation's signature, for `rehab models import`).
    Named by its file's stem, as the learned models."""
    path = Path(path)
    document = checked_document(path, FORMAT, FORMAT_VERSION,
                                "rehab emg model --for-assistance --save NAME",
                                "Save the model again from its trials, or restore the file "
                                "from its copy.", noun="an EMG model file", signed=signed)
    check_numbers(path, "weights", document.get("model"))
    try:
        model = model_from_dict(document["model"])
        taken = tuple(str(m) for m in document["muscles"])
        settings = EmgSettings.from_dict(document["settings"])
        dt_s = float(document["dt_s"])
        as_live = document["as_live"]
        if not isinstance(as_live, bool):
            raise ValueError(f"as_live {as_live!r}")
        latency_s = float(document["latency_s"])
        if not 0.0 <= latency_s <= 1.0:
            raise ValueError(f"latency {latency_s} s")
        if not 0.0 < dt_s <= 1.0:
            raise ValueError(f"time step {dt_s} s")
        # judged by the console's rule, whatever threshold the file carries
        validations = tuple(Validation.from_dict({
            **v, "threshold_r2": max(float(v["threshold_r2"]), USABLE_R2),
            "threshold_agreement": max(float(v.get("threshold_agreement", 0.0)),
                                       USABLE_CONE_AGREEMENT)})
            for v in document["validations"])
    except (KeyError, TypeError, ValueError, AttributeError, ParameterError) as exc:
        raise ModelFileError(path, "format", f"its model is incomplete ({exc})",
                             "Save the model again from its trials.") from None
    if inputs_of(model) != len(taken):
        raise ModelFileError(path, "format", f"the model takes {inputs_of(model)} envelopes "
                             f"for {len(taken)} muscles", "Save the model again.")
    if not validations:
        raise ModelFileError(path, "not approved", "it carries no held-out validation",
                             "Save it with `rehab emg model --for-assistance --save`.")
    try:
        approve(model, list(validations))
    except ModelNotApproved as exc:
        raise ModelFileError(path, "not approved", str(exc), "Use a model that passes, or "
                             "the force sensor.") from None
    if muscles is not None and tuple(muscles) != taken:
        raise ModelFileError(path, "muscles", f"the model takes {', '.join(taken)}, the "
                             f"session has {', '.join(muscles) or 'none'}",
                             "Record those muscles, or choose a model of these.")
    return EmgModelFile(path, path.stem, model, taken, settings,
                        validations, tuple(map(str, document.get("trials", ()))), dt_s,
                        as_live, latency_s, document["content_sha256"])


def emg_model(models_dir: str | Path, name: str, muscles=None) -> EmgModelFile:
    """The EMG model `name` of the data folder's models/emg/, read and checked."""
    return read_emg_model(model_path(models_dir, name), muscles)


def emg_model_names(models_dir: str | Path) -> list[str]:
    folder = models_folder(models_dir)
    if not folder.is_dir():
        return []
    return sorted(p.stem for p in folder.iterdir()
                  if p.suffix == SUFFIX and p.is_file() and MODEL_NAME.fullmatch(p.stem))
