"""Synthetic EMG subjects: virtual patients whose joint torques drive a muscle model, so the
muscle activations behind every EMG sample are known (core.emg.synthetic).

A synthetic trial is a headless trial on the simulator (app.trials.headless) with a
virtual patient; its recorded net joint torques (`subject_torque`, eq. 3.27, what the
thesis's network was asked to predict) are shared among the muscles, turned into
excitations and EMG, and stored in the trial's `/emg` group like an imported recording,
on the trial's clock. Each subject has its own electrodes (gains, crosstalk) and muscles
(moment arms, strengths) drawn from its seed, and its own MVC contractions, which may be
bad (`bad_mvc`, as the thesis's subject 2's deltoid).

`thesis_design` makes the thesis's data set: 4 subjects, two sessions, 3 trials each
(2 + 1), the MVC per session.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from app.trials.headless import save, simulate
from core.emg.synthetic import (
    MUSCLES,
    THESIS_MUSCLES,
    Electrodes,
    MuscleModel,
    activations_from_torques,
    emg_from_excitations,
    excitation_from_activations,
    joint_torques,
    mvc_contraction,
)
from core.trial import THESIS_SUBJECT, TrialParameters
from device.emg.files import write_plain_csv
from device.recording.emgfile import write_emg
from device.safewrite import make_private_folders

SYNTHETIC_SOURCE = "synthetic"


@dataclass(frozen=True, slots=True)
class Subject:
    """One synthetic subject: its muscles, its electrodes and its virtual patient."""

    number: int
    model: MuscleModel
    electrodes: Electrodes
    patient: str = "healthy"
    muscles: tuple[str, ...] = THESIS_MUSCLES
    drive_N: float = 6.0  # how firmly the subject pushes the handle along the path

    @classmethod
    def drawn(cls, number: int, *, patient: str = "healthy", muscles=THESIS_MUSCLES,
              bad_mvc: dict[str, float] | None = None) -> Subject:
        """A subject whose body and electrodes vary around the defaults by its number."""
        rng = np.random.default_rng(1000 + number)
        base_model, base_electrodes = MuscleModel(), Electrodes()
        arms = np.asarray(base_model.moment_arms_m) * rng.uniform(0.8, 1.2, (4, 1))
        forces = np.asarray(base_model.max_force_N) * rng.uniform(0.7, 1.3, 4)
        model = replace(base_model, moment_arms_m=tuple(map(tuple, arms.tolist())),
                        max_force_N=tuple(forces.tolist()),
                        cocontraction=float(rng.uniform(0.01, 0.06)))
        gains = np.asarray(base_electrodes.gain_V) * rng.uniform(0.5, 1.5, 4)
        crosstalk = np.asarray(base_electrodes.crosstalk) * rng.uniform(0.5, 1.5, (4, 4))
        shares = [1.0] * 4
        for muscle, share in (bad_mvc or {}).items():
            shares[MUSCLES.index(muscle)] = share
        electrodes = replace(base_electrodes, gain_V=tuple(gains.tolist()),
                             crosstalk=tuple(map(tuple, crosstalk.tolist())),
                             bad_mvc=tuple(shares))
        return cls(number, model, electrodes, patient, tuple(muscles),
                   float(rng.uniform(4.0, 8.0)))


# the thesis's subjects moved the handle with the motors giving no help: the push is theirs
DEMO_PARAMETERS = THESIS_SUBJECT.replace(repetitions=1, assistance_level=0.0)
"""A synthetic subject's trial unless told otherwise: one D of the thesis's, no help."""


@dataclass(frozen=True, slots=True, eq=False)
class SyntheticTrial:
    path: Path
    subject: Subject
    torques_Nm: np.ndarray  # (N, 2) anatomical shoulder, elbow, on the trial's ticks
    excitation: np.ndarray  # (N, 4) the truth behind the EMG
    time_s: np.ndarray


def record_trial(path: str | os.PathLike, subject: Subject, *, seed: int,
                 parameters: TrialParameters | None = None,
                 engine: str = "auto") -> SyntheticTrial:
    """A headless trial of the subject's virtual patient, with its EMG in `/emg`."""
    parameters = parameters or DEMO_PARAMETERS
    options = {"drive_N": subject.drive_N} if subject.patient != "passive" else None
    trial = simulate(parameters, patient=subject.patient, seed=seed, engine=engine,
                     patient_options=options)
    path = Path(path)
    save(trial, path, subject_code=f"SYN{subject.number}")
    records = trial.records
    dt = trial.plan.period_s
    torques = joint_torques(np.nan_to_num(records["subject_torque"]))
    excitation = excitation_from_activations(
        activations_from_torques(torques, subject.model), dt, subject.model)
    t_emg, emg = emg_from_excitations(excitation, dt, subject.electrodes,
                                      seed=10_000 * subject.number + seed,
                                      t0_s=float(records["time"][0]))
    channels = [MUSCLES.index(m) for m in subject.muscles]
    write_emg(path, names=tuple(f"EMG{i + 1}" for i in range(len(channels))),
              muscles=subject.muscles, rate_hz=subject.electrodes.rate_hz, time_s=t_emg,
              samples=emg[:, channels], source=SYNTHETIC_SOURCE,
              clock="synthetic: made on the trial's clock", offset_s=0.0)
    return SyntheticTrial(path, subject, torques, excitation, records["time"].copy())


def contraction_path(folder: str | os.PathLike, subject: Subject, session: int,
                     muscle: str) -> Path:
    """Where write_contractions puts a muscle's contraction."""
    return Path(folder) / f"S{subject.number}_session{session}_mvc_{muscle}.csv"


def write_contractions(folder: str | os.PathLike, subject: Subject, session: int) -> dict:
    """The subject's MVC contraction of each of its muscles for one session, each a plain
    CSV with the subject's channels (new files: an existing one is kept and refused,
    device.safewrite); returns {muscle: path}."""
    folder = make_private_folders(folder)
    channels = [MUSCLES.index(m) for m in subject.muscles]
    names = tuple(f"EMG{i + 1}" for i in range(len(channels)))
    out = {}
    for muscle in subject.muscles:
        t, emg = mvc_contraction(muscle, subject.electrodes,
                                 seed=100 * subject.number + 10 * session
                                 + MUSCLES.index(muscle))
        path = contraction_path(folder, subject, session, muscle)
        write_plain_csv(path, names, t, emg[:, channels])
        out[muscle] = (path, names[subject.muscles.index(muscle)])
    return out


def record_session(folder: str | os.PathLike, subject: Subject, *, trials: int = 3,
                   repetitions: int = 2, tolerance_rad: float | None = None,
                   session: int = 1) -> list[Path]:
    """One session of a subject for an EMG model that is to feed the assistance: `trials`
    trials of `repetitions` repetitions of the thesis's D with the motors giving no help
    (at `tolerance_rad`, the cone the model will be validated for; default the thesis's),
    and the session's MVCs stored in each (app.emg.session.session_mvc)."""
    from app.emg.session import Contraction, session_mvc

    folder = Path(folder)
    params = THESIS_SUBJECT.replace(repetitions=repetitions, assistance_level=0.0)
    if tolerance_rad is not None:
        params = params.replace(tolerance_rad=tolerance_rad)
    paths = [record_trial(folder / f"S{subject.number}_session{session}_w{k + 1}.h5", subject,
                          seed=k, parameters=params).path for k in range(trials)]
    contractions = write_contractions(folder, subject, session)
    session_mvc(paths, [Contraction(m, p, ch) for m, (p, ch) in contractions.items()],
                full_scale_V=subject.electrodes.full_scale_V)
    return paths


# The thesis's design (section 5.2.1): 4 subjects; session 1 two trials, session 2 one.
THESIS_SESSIONS = ((1, 2), (2, 1))


def thesis_design(folder: str | os.PathLike, *, subjects: int = 4, muscles=THESIS_MUSCLES,
                  bad_mvc: dict[int, dict[str, float]] | None = None,
                  engine: str = "auto") -> list[tuple[Subject, int, Path]]:
    """The thesis's data set, synthetic: each subject's sessions (THESIS_SESSIONS), each
    session's MVC contractions stored in its trials (app.emg.session.session_mvc).
    `bad_mvc` {subject: {muscle: share}} (default: subject 2's anterior deltoid at 15 % of
    a maximal effort, so its reach reads near 90 % MVC and more, as the thesis's subject 2
    did). Returns (subject, session, trial file) in order."""
    from app.emg.session import Contraction, session_mvc

    folder = Path(folder)
    bad_mvc = {2: {"anterior_deltoid": 0.15}} if bad_mvc is None else bad_mvc
    out = []
    for number in range(1, subjects + 1):
        subject = Subject.drawn(number, muscles=muscles, bad_mvc=bad_mvc.get(number))
        for session, n_trials in THESIS_SESSIONS:
            paths = []
            for k in range(n_trials):
                path = folder / f"S{number}_session{session}_trial{k + 1}.h5"
                record_trial(path, subject, seed=10 * session + k, engine=engine)
                paths.append(path)
            contractions = write_contractions(folder, subject, session)
            session_mvc(paths, [Contraction(m, p, ch) for m, (p, ch) in contractions.items()],
                        full_scale_V=subject.electrodes.full_scale_V)
            out += [(subject, session, p) for p in paths]
    return out


def model_data(path: str | os.PathLike, subject: int, *, step: int = 10,
               as_live: bool = False):
    """A trial's exercise as a core.emg.models.TrialSet: the % MVC envelopes and the
    anatomical torques on every `step`-th tick where both are known, with the arm's
    state, the sensor's force and the cone there (core.emg.force.ForceContext). `as_live`:
    the envelopes a live console had at each tick (app.emg.session.trial_envelopes), to
    train a model for the assistance on what it will be given."""
    from app.emg.session import trial_envelopes
    from app.trials.reader import read_trial
    from core.emg.force import ForceContext
    from core.emg.models import TrialSet

    path = Path(path)
    trial = read_trial(path)
    env = trial_envelopes(path, as_live=as_live)
    torques = joint_torques(trial.channels["subject_torque"])
    keep = (trial.channels["phase"] == 2) & np.isfinite(env.values).all(axis=1) \
        & np.isfinite(torques).all(axis=1)
    index = np.flatnonzero(keep)[::step]
    ch = trial.channels
    context = ForceContext(trial.parameters.arm(), ch["subject_angle"][index],
                           ch["subject_rate"][index], ch["subject_acceleration"][index],
                           ch["force"][index], ch["direction_desired"][index],
                           trial.parameters.tolerance_rad)
    return TrialSet(env.values[index], torques[index], subject, path.stem,
                    step * trial.sample_period_s, context)
