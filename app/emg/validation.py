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
from dataclasses import dataclass
from pathlib import Path

import numpy as np

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
from core.emg.processing import EmgSettings

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


@dataclass(frozen=True, eq=False)
class CheckedModel:
    """A model's held-out validations, the model fitted on all the trials, and what it
    takes: the muscles, the EMG processing the trials' MVCs were made with, the time step
    of its envelopes."""

    validations: list[Validation]
    model: object
    muscles: tuple[str, ...]
    settings: EmgSettings
    dt_s: float
    trials: tuple[Path, ...]
    as_live: bool = False
    """Trained on the envelopes a live console has (their windows ending at each tick)."""
    latency_s: float = 0.0
    """How late the live source was taken to deliver each sample in the replay."""


def trial_sets(trials, *, as_live: bool = False):
    """Each trial file as a core.emg.models.TrialSet, its subject the trial's subject code,
    with the muscles and the EMG settings they share; `as_live`, the envelopes a live
    console had at each tick (app.emg.subjects.model_data)."""
    from app.emg.subjects import model_data
    from app.trials.reader import read_trial
    from device.recording.emgfile import read_emg

    sets, muscles, settings = [], None, None
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
        made = {EmgSettings.from_dict((emg.mvc.get(m) or {}).get("settings"))
                for m in emg.muscles}
        if settings is not None:
            made.add(settings)
        if len(made) > 1:
            raise EmgImportError(f"trial file {path.name}: its MVCs were made with other EMG "
                                 "settings than the other trials' (window, band or notch); "
                                 "store the MVCs of every trial with the same settings")
        settings = made.pop()
        subject = read_trial(path, channels=()).subject
        sets.append(model_data(path, subject.code if subject else path.stem, as_live=as_live))
    return sets, muscles, settings


def check_model(trials, name: str, *, test: list[str | os.PathLike] | None = None,
                as_live: bool = False, latency_s: float = 0.0) -> CheckedModel:
    """The model's held-out validations on the trials, and the model fitted on all of them.
    `as_live`: trained on the envelopes a live console has at each tick (the model for
    the assistance, which is fed them, app.emg.estimate), not the centred ones; its force
    is replayed with the live source's `latency_s` (app.emg.estimate.replay_trial)."""
    paths = [Path(t).resolve() for t in trials]
    sets, muscles, settings = trial_sets(paths, as_live=as_live)
    make = maker(name, muscles)
    judge = replayed(dict(zip((s.name for s in sets), paths, strict=True)), muscles, settings,
                     as_live, latency_s)
    if test:
        held = {Path(t).resolve().stem for t in test}
        unknown = held - {p.stem for p in paths}
        if unknown:
            raise EmgImportError(f"--test {', '.join(sorted(unknown))}: not among the trials "
                                 "given; a held-out trial must be one of them")
        if len(held) == len(paths):
            raise EmgImportError("every trial is held out: leave some to train on")
        validations = [validate(make, sets, held, "held-out trials", judge)]
    else:
        if len({s.subject for s in sets}) < 2:
            raise EmgImportError("all the trials are of one subject: give trials of two or "
                                 "more subjects (leave one subject out), or --test TRIAL")
        validations = leave_one_subject_out(make, sets, judge)
    return CheckedModel(validations, make().fit(sets), tuple(muscles), settings,
                        float(sets[0].dt_s), tuple(paths), as_live, latency_s)


def replayed(paths: dict[str, Path], muscles, settings: EmgSettings, as_live: bool,
             latency_s: float):
    """The judge of a model's force for the assistance (core.emg.models.validate): each
    held-out trial replayed through the live estimator (app.emg.estimate.replay_trial,
    causal: only the EMG recorded up to each tick), scored against the sensor's force."""
    from app.emg.estimate import replay_trial
    from core.emg.force import compared

    def judge(model, test_sets):
        parts = [replay_trial(model, muscles, settings, t.dt_s, paths[t.name],
                              as_live=as_live, latency_s=latency_s) for t in test_sets]
        tolerances = {round(p[4], 12) for p in parts}
        if len(tolerances) > 1:
            raise EmgImportError("the held-out trials have different tolerances; hold out "
                                 "trials of one tolerance together")
        return compared(*(np.concatenate([p[i] for p in parts]) for i in (1, 2, 3)),
                        parts[0][4])

    return judge


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
