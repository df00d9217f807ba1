"""Whether an EMG-to-torque model may stand in for the force sensor as the estimate of the
patient's torque (thesis section 5, the cHRI aim): validated held out on the researcher's
own trials, and refused in words when it does not pass.

The trials are files with EMG and the session's MVCs (`/emg/mvc`); each gives its % MVC
envelopes and its anatomical torques (app.emg.subjects.model_data), its subject being the
trial's subject code. The validation is the thesis's (train on all but the trials given
as `test`, score on those) or, without `test`, leave one subject out; each against the
linear baseline (core.emg.models.validate). `approve` then passes the model fitted on all
the trials only if every validation passed (core.emg.models.torque_estimator, threshold
core.emg.models.USABLE_R2); otherwise it raises ModelNotApproved, whose one line says why.
"""

from __future__ import annotations

import os
from pathlib import Path

from app.emg.importing import EmgImportError
from core.emg.models import (
    FeedForwardNetwork,
    LinearModel,
    ModelRefused,
    MuscleModel,
    Validation,
    leave_one_subject_out,
    torque_estimator,
    validate,
)

MODELS = ("linear", "network", "muscle")


class ModelNotApproved(EmgImportError):
    """A model that did not pass its held-out validation was asked to feed the assistance."""


def maker(name: str, muscles):
    if name == "linear":
        return LinearModel
    if name == "network":
        return FeedForwardNetwork
    if name == "muscle":
        return lambda: MuscleModel(muscles)
    raise EmgImportError(f"model {name!r}: choose one of {', '.join(MODELS)}")


def trial_sets(trials):
    """Each trial file as a core.emg.models.TrialSet, its subject the trial's subject code."""
    from app.emg.subjects import model_data
    from app.trials.reader import read_trial
    from device.recording.emgfile import read_emg

    sets, muscles = [], None
    for path in map(Path, trials):
        emg = read_emg(path)
        if emg is None:
            raise EmgImportError(f"trial file {path.name} has no EMG; import it first "
                                 "(rehab emg import TRIAL FILE)")
        if muscles is not None and emg.muscles != muscles:
            raise EmgImportError(f"trial file {path.name} has the muscles "
                                 f"{', '.join(emg.muscles)}, the others {', '.join(muscles)}: "
                                 "a model takes the same muscles from every trial")
        muscles = emg.muscles
        subject = read_trial(path, channels=()).subject
        sets.append(model_data(path, subject.code if subject else path.stem))
    return sets, muscles


def check_model(trials, name: str, *, test: list[str | os.PathLike] | None = None,
                ) -> tuple[list[Validation], object]:
    """The model's held-out validations on the trials, and the model fitted on all of them."""
    paths = [Path(t).resolve() for t in trials]
    sets, muscles = trial_sets(paths)
    make = maker(name, muscles)
    if test:
        held = {Path(t).resolve().stem for t in test}
        unknown = held - {p.stem for p in paths}
        if unknown:
            raise EmgImportError(f"--test {', '.join(sorted(unknown))}: not among the trials "
                                 "given; a held-out trial must be one of them")
        if len(held) == len(paths):
            raise EmgImportError("every trial is held out: leave some to train on")
        validations = [validate(make, sets, held, "held-out trials")]
    else:
        if len({s.subject for s in sets}) < 2:
            raise EmgImportError("all the trials are of one subject: give trials of two or "
                                 "more subjects (leave one subject out), or --test TRIAL")
        validations = leave_one_subject_out(make, sets)
    return validations, make().fit(sets)


def approve(model, validations: list[Validation]):
    """The model, for the assistance, only if every held-out validation passed."""
    failed = []
    for validation in validations:
        try:
            torque_estimator(model, validation)
        except ModelRefused:
            failed.append(validation)
    if failed:
        raise ModelNotApproved(f"refused as the patient's force estimate: {failed[0].why_not}"
                               + (f" ({len(failed)} of {len(validations)} validations fail)"
                                  if len(validations) > 1 else ""))
    return model
