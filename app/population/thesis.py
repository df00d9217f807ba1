"""The virtual population on the thesis's experiment (section 3.6), figure by figure against
the thesis's healthy subject.

Every subject runs the thesis's D with the thesis's settings (core.trial.thesis_experiment:
SMC with the thesis's identified gains, the thesis mode at 100 %, 4 s constant-speed laps,
20° cone, the shoulder where we read it) with its own body, its right arm (the thesis
tested the right arm), its settled behaviour, on the realistic plant, headless
(app.trials.headless.simulate). A subject whose arm cannot reach the whole D from that
shoulder is left out with the reason, as the console would refuse the trial.

THESIS_FIGURES says which figures calibrated the model (the two RMSEs: the thesis SMC's
gains and the guided impedance, docs/validation.md) and which are held out (the force
ranges, the directional performance, the shoulder range): only the held-out ones test the
model. The elbow's range is listed for completeness: on the printed D with 12 in segments
it is 60°, not the thesis's 31° (docs/validation.md, Trial geometry), which no subject's
behaviour changes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from app.population.pool import map_subjects
from app.trials.analysis import analyse
from app.trials.headless import simulate
from core.errors import ParameterError, UnreachableError
from core.trial import thesis_experiment
from device.sim.population import Subject, draw_population


@dataclass(frozen=True, slots=True)
class ThesisFigure:
    key: str
    """Our figure's key in the trial's metrics."""
    label: str
    unit: str
    scale: float
    """From SI to the unit shown."""
    thesis: float
    """The thesis's healthy subject's value (section 3.6), in `unit`."""
    role: str
    """"calibrated", "held out" or "geometry" (see the module notes)."""


THESIS_FIGURES = (
    ThesisFigure("rmse_x_m", "RMSE x", "mm", 1e3, 8.68, "calibrated"),
    ThesisFigure("rmse_y_m", "RMSE y", "mm", 1e3, 7.02, "calibrated"),
    ThesisFigure("directional_performance_pct", "directional performance", "%", 1.0, 78.0,
                 "held out"),
    ThesisFigure("force_range_x_N", "force range x", "N", 1.0, 0.835, "held out"),
    ThesisFigure("force_range_y_N", "force range y", "N", 1.0, 2.528, "held out"),
    ThesisFigure("shoulder_rom_rad", "shoulder ROM (ISB)", "°", 180.0 / math.pi, 42.17,
                 "held out"),
    ThesisFigure("elbow_rom_rad", "elbow ROM (ISB)", "°", 180.0 / math.pi, 30.65, "geometry"),
)
THESIS_SIDE = "right"


def thesis_figures(subject: Subject, repetitions: int = 5, plant: str = "realistic",
                   engine: str = "auto") -> dict:
    """The subject's figures on the thesis's experiment, in SI units by THESIS_FIGURES'
    keys, with "subject" (its index) and "refused" ("" or why the trial was refused)."""
    params = subject.trial_parameters(thesis_experiment(repetitions=repetitions), THESIS_SIDE)
    out = {"subject": subject.index, "refused": ""}
    try:
        trial = simulate(params, patient="healthy", seed=subject.trial_seed(0), plant=plant,
                         patient_options=subject.patient_options(side=THESIS_SIDE, guided=True),
                         engine=engine)
    except (UnreachableError, ParameterError) as error:
        out["refused"] = str(error)
        out.update({f.key: math.nan for f in THESIS_FIGURES})
        return out
    channels = {n: trial.records[n] for n in trial.records.dtype.names}
    metrics = analyse(channels, params).metrics.to_dict()
    out.update({f.key: float(metrics[f.key]) for f in THESIS_FIGURES})
    out["status"] = trial.status
    return out


@dataclass(frozen=True, slots=True)
class Spread:
    figure: ThesisFigure
    values: np.ndarray
    """The subjects' values in the figure's unit (refused subjects left out)."""

    @property
    def low(self) -> float:
        return float(np.min(self.values))

    @property
    def high(self) -> float:
        return float(np.max(self.values))

    def percentile(self, q: float) -> float:
        return float(np.percentile(self.values, q))

    @property
    def contains_thesis(self) -> bool:
        return self.low <= self.figure.thesis <= self.high


def against_thesis(n: int, seed: int, *, workers: int = 2, repetitions: int = 5,
                   plant: str = "realistic") -> tuple[list[dict], list[Spread]]:
    """The population of `seed`'s first `n` subjects on the thesis's experiment: every
    subject's figures (in order) and each figure's spread over the subjects who ran."""
    subjects = draw_population(n, seed)
    rows = map_subjects(_Bound(repetitions, plant), subjects, workers)
    ran = [r for r in rows if not r["refused"]]
    spreads = [Spread(f, np.array([r[f.key] * f.scale for r in ran])) for f in THESIS_FIGURES]
    return rows, spreads


@dataclass(frozen=True, slots=True)
class _Bound:
    """thesis_figures with its settings, picklable for the workers."""

    repetitions: int
    plant: str

    def __call__(self, subject: Subject) -> dict:
        return thesis_figures(subject, self.repetitions, self.plant)
