"""A population of virtual healthy subjects: bodies, ages, sexes, handedness, a subject's
own way of moving, trial-to-trial variability and learning, all drawn from one seed.

Each `Subject` is a healthy virtual patient (device.sim.patients, kind "healthy") with its
own arm and its own patient options. `draw_population(n, seed)` is deterministic: the same
seed gives the same subjects, subject k is the same whatever n, and a subject's trials
draw their seeds from the subject's own stream (`Subject.trial_seed`).

The body
--------
* sex: female or male with equal probability.
* age: uniform over 20–85 years (the range over which clinical norms are usually made).
* height: normal, 1.76 ± 0.07 m for men and 1.63 ± 0.065 m for women (adult means of
  the order of European and North American surveys), clipped to ±3 SD.
* mass: from a body-mass index drawn normal 26 ± 4 kg/m², clipped to 18–40.
* segments: Winter (2009, Biomechanics and Motor Control of Human Movement, Table 4.1):
  upper arm 0.186 H, forearm 0.146 H, hand 0.108 H. The robot's forearm link ends at the
  grip, so `forearm_m` = forearm + GRIP_FRACTION × hand. Each proportion varies from
  person to person by SEGMENT_CV (about 4 % SD, the spread of segment-to-height ratios in
  anthropometric surveys). The thesis's subject (180 cm, 12 in + 12 in) sits inside it.
* handedness: left with probability LEFT_HANDED (about one in ten, Papadatou-Pastou et
  al. 2020, Psychol. Bull. 146:481).

How a subject moves (the calibrated centre, then the spread)
-------------------------------------------------------------
The centre is the healthy subject of the thesis's experiment (section 3.6) as calibrated
in docs/validation.md ("Why the virtual subject tracked 10x better"): the active joint
impedance is GUIDED_IMPEDANCE_SCALE × device.sim.patient_parameters.HEALTHY_IMPEDANCE (a subject
who is being guided round a path relaxes: the reaching values of Burdet et al. 2001 were
measured against an unstable load, where people co-contract), the push along the path
DRIVE_N (patient_parameters.DRIVE_N). Calibrated on the RMSE x and y of section 3.6 only; the
force ranges, the directional performance and the shoulder range are held out. On their
own — the assessment battery, where the robot is transparent or the subject follows their
own plan — the same subject holds their reaching impedance, HEALTHY_IMPEDANCE's order
(`Subject.patient_options(guided=False)`): the guided quarter is a relaxation under the
robot's lead, not how people reach to a target.

Around it each subject draws, log-normally (median the centre times the age and sex
factors below):
* impedance scale (CV 0.35) and push (CV 0.30): people differ in how stiffly they hold
  the arm and how hard they lead;
* strength: women's upper-limb strength is about 0.6 of men's, and strength falls by
  about 1 % a year after 50 (orders of magnitude of the sarcopenia literature); the
  push and the impedance scale with it (a stiffer arm is a more strongly activated one);
* reaction time (s) to a visual target: 0.25 s at 20 rising 1.5 ms a year, SD 0.03 s;
* speed: a preferred movement speed 1 at 20 falling 0.4 % a year (older adults reach
  more slowly), CV 0.12;
* variability: the trial-to-trial coefficient of variation of effort and push
  (patients.VARIABILITY's meaning) 0.08 at 20 plus 0.001 a year, CV 0.3;
* the non-dominant arm: 7 % weaker (the "10 % rule" of grip strength is an
  overestimate; 5–10 %) and 15 % more variable.

Learning across trials
----------------------
A new task is done worse at first: trial n's variability, reaction time and the share of
the push a subject dares are LEARNING_GAIN of their settled value's excess at trial 0,
decaying as exp(−n / learning_trials), learning_trials drawn log-normal around
LEARNING_TRIALS (a few trials, the order of the fast process in motor adaptation). The
tests check that it is deterministic and that the first trials are more variable.

These are model choices of the order the literature reports, not a fit to a cohort; the
simulated normative model built from them says so on every report that uses it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError
from core.trial import TrialParameters
from device.sim.patient_parameters import DRIVE_N, HEALTHY_IMPEDANCE

SEXES = ("female", "male")
HANDEDNESS = ("right", "left")
AGE_RANGE_YEARS = (20.0, 85.0)
HEIGHT_M = {"male": (1.76, 0.07), "female": (1.63, 0.065)}
BMI_KG_M2 = (26.0, 4.0)
BMI_RANGE_KG_M2 = (18.0, 40.0)
WINTER_UPPER_ARM = 0.186
WINTER_FOREARM = 0.146
WINTER_HAND = 0.108
GRIP_FRACTION = 0.4
"""Where the grip sits along the hand, as a fraction of its length from the wrist."""
SEGMENT_CV = 0.04
LEFT_HANDED = 0.10

GUIDED_IMPEDANCE_SCALE = 0.25
"""The calibrated active impedance of a guided healthy subject, as a fraction of
HEALTHY_IMPEDANCE (docs/validation.md)."""
IMPEDANCE_CV = 0.35
DRIVE_CV = 0.30
FEMALE_STRENGTH = 0.6
STRENGTH_LOSS_PER_YEAR = 0.01
STRENGTH_LOSS_FROM_YEARS = 50.0
REACTION_S = (0.25, 0.0015, 0.03)
"""Reaction time at 20 years, its rise per year, its SD between subjects."""
SPEED = (1.0, 0.004, 0.12)
"""Preferred speed at 20 years (relative), its fall per year, its CV."""
VARIABILITY = (0.08, 0.001, 0.3)
"""Trial-to-trial CV at 20 years, its rise per year, its CV between subjects."""
NON_DOMINANT_STRENGTH = 0.93
NON_DOMINANT_VARIABILITY = 1.15
LEARNING_TRIALS = 3.0
LEARNING_GAIN = 0.5
"""At the first trial variability and reaction time are (1 + LEARNING_GAIN) of their
settled value and the push (1 − LEARNING_GAIN / 2) of it."""
MAX_SUBJECTS = 1_000_000


def _lognormal(rng: np.random.Generator, median: float, cv: float) -> float:
    sigma = math.sqrt(math.log1p(cv * cv))
    return float(median * math.exp(rng.normal(0.0, sigma)))


def _clipped_normal(rng: np.random.Generator, mean: float, sd: float, low: float,
                    high: float) -> float:
    return float(min(high, max(low, rng.normal(mean, sd))))


@dataclass(frozen=True, slots=True)
class Subject:
    """One virtual healthy subject (SI units; see the module notes for every draw)."""

    index: int
    population_seed: int
    age_years: float
    sex: str
    handedness: str
    height_m: float
    body_mass_kg: float
    upper_arm_m: float
    forearm_m: float
    strength: float
    """Relative to a 20–50-year-old man's (1)."""
    impedance_scale: float
    """Of HEALTHY_IMPEDANCE, for the dominant arm at the settled trial, being guided
    (patient_options: on their own it is this over GUIDED_IMPEDANCE_SCALE)."""
    drive_N: float
    """The push along the path, dominant arm, settled."""
    reaction_time_s: float
    speed_scale: float
    variability: float
    learning_trials: float

    @property
    def code(self) -> str:
        """A pseudonymous code for the registry: SIM + population seed + index."""
        return f"SIM{self.population_seed}-{self.index:05d}"

    @property
    def birth_year(self) -> int:
        """For a registry dated 2026 (the session's date decides the age used in norms)."""
        return 2026 - int(self.age_years)

    def dominant(self, side: str) -> bool:
        return side == self.handedness

    def learned(self, trial: int) -> float:
        """How much is left to learn at trial `trial` (0, 1, ...): 1 at the first, → 0."""
        if trial < 0:
            raise ParameterError("trial", trial, "0 or more", "the subject's trial count")
        return math.exp(-trial / self.learning_trials)

    def reaction_time_at(self, trial: int) -> float:
        """The reaction time (s) at trial `trial`, learning included."""
        return self.reaction_time_s * (1.0 + LEARNING_GAIN * self.learned(trial))

    def variability_at(self, trial: int, side: str) -> float:
        """The trial-to-trial CV at trial `trial` with the arm on `side`."""
        cv = self.variability * (1.0 + LEARNING_GAIN * self.learned(trial))
        if not self.dominant(side):
            cv *= NON_DOMINANT_VARIABILITY
        return min(cv, 1.0)

    def patient_options(self, trial: int = 1_000, side: str | None = None, *,
                        guided: bool) -> dict:
        """make_patient options of a "healthy" patient for this subject's trial `trial`
        with the arm on `side` (default: the dominant one); trial 1000 is settled.

        `guided`: the robot leads the hand round a path (the thesis's experiment), and the
        subject holds the arm at the calibrated guided impedance (`impedance_scale`);
        else (the assessment battery: the robot transparent, or holding or moving the hand
        while the subject acts on their own plan) at their own reaching impedance, that
        scale over GUIDED_IMPEDANCE_SCALE (HEALTHY_IMPEDANCE's order, Burdet et al. 2001,
        measured while people reach). Held at the guided quarter in the battery, 70 % of
        the 482 simulated controls left reaches without a movement end (4.3 of 16 on
        average; 12 of them all 16) and drew circles of ratio 0.80: a relaxed arm on a
        transparent robot does not settle on a target (docs/norms.md)."""
        side = side or self.handedness
        factor = 1.0 if self.dominant(side) else NON_DOMINANT_STRENGTH
        scale = self.impedance_scale if guided else self.impedance_scale / GUIDED_IMPEDANCE_SCALE
        k = tuple(scale * factor * v for v in HEALTHY_IMPEDANCE.stiffness_Nm_rad)
        b = tuple(scale * factor * v for v in HEALTHY_IMPEDANCE.damping_Nms_rad)
        drive = self.drive_N * factor * (1.0 - 0.5 * LEARNING_GAIN * self.learned(trial))
        return {"stiffness_Nm_rad": k, "damping_Nms_rad": b, "drive_N": drive,
                "variability": self.variability_at(trial, side)}

    def trial_seed(self, trial: int) -> int:
        """The seed of this subject's trial `trial` (the patient's draws, the sensor's
        noise): the subject's own stream, so it does not depend on the population's size."""
        sequence = np.random.SeedSequence(self.population_seed, spawn_key=(self.index, 1, trial))
        return int(sequence.generate_state(1)[0])

    def trial_parameters(self, base: TrialParameters, side: str | None = None
                         ) -> TrialParameters:
        """`base` with this subject's body and tested arm (default: the dominant one)."""
        return base.replace(body_mass_kg=self.body_mass_kg, upper_arm_m=self.upper_arm_m,
                            forearm_m=self.forearm_m, side=side or self.handedness)

    def covariates(self, side: str | None = None) -> dict:
        """The norm covariates of this subject (issue 31's names)."""
        return {"age_years": self.age_years, "sex": self.sex, "handedness": self.handedness,
                "tested_side": side or self.handedness}


def draw_subject(population_seed: int, index: int) -> Subject:
    """Subject `index` of the population of `population_seed` (its own stream)."""
    rng = np.random.default_rng(np.random.SeedSequence(int(population_seed),
                                                       spawn_key=(int(index), 0)))
    sex = SEXES[int(rng.integers(2))]
    age = float(rng.uniform(*AGE_RANGE_YEARS))
    left = bool(rng.random() < LEFT_HANDED)
    mean_h, sd_h = HEIGHT_M[sex]
    height = _clipped_normal(rng, mean_h, sd_h, mean_h - 3 * sd_h, mean_h + 3 * sd_h)
    bmi = _clipped_normal(rng, *BMI_KG_M2, *BMI_RANGE_KG_M2)
    upper = height * _lognormal(rng, WINTER_UPPER_ARM, SEGMENT_CV)
    forearm = height * (_lognormal(rng, WINTER_FOREARM, SEGMENT_CV)
                        + GRIP_FRACTION * _lognormal(rng, WINTER_HAND, SEGMENT_CV))
    strength = (FEMALE_STRENGTH if sex == "female" else 1.0) * (
        1.0 - STRENGTH_LOSS_PER_YEAR * max(0.0, age - STRENGTH_LOSS_FROM_YEARS))
    # the median of the calibrated centre is a young man's; scaled by strength
    impedance = _lognormal(rng, GUIDED_IMPEDANCE_SCALE * strength, IMPEDANCE_CV)
    drive = _lognormal(rng, DRIVE_N * strength, DRIVE_CV)
    years = age - AGE_RANGE_YEARS[0]
    reaction = max(0.12, rng.normal(REACTION_S[0] + REACTION_S[1] * years, REACTION_S[2]))
    speed = _lognormal(rng, SPEED[0] - SPEED[1] * years, SPEED[2])
    variability = _lognormal(rng, VARIABILITY[0] + VARIABILITY[1] * years, VARIABILITY[2])
    learning = _lognormal(rng, LEARNING_TRIALS, 0.5)
    return Subject(int(index), int(population_seed), age, sex, "left" if left else "right",
                   height, bmi * height * height, upper, forearm, strength, impedance, drive,
                   float(reaction), speed, min(variability, 0.5), learning)


def draw_population(n: int, seed: int) -> tuple[Subject, ...]:
    """`n` subjects of the population of `seed` (deterministic; subject k the same for any
    n > k)."""
    if isinstance(n, bool) or not isinstance(n, int | np.integer) or not 1 <= n <= MAX_SUBJECTS:
        raise ParameterError("subjects", n, f"a whole number from 1 to {MAX_SUBJECTS}")
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError("seed", seed, "a whole number ≥ 0")
    return tuple(draw_subject(int(seed), k) for k in range(int(n)))
