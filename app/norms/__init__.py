"""Normative models at the console: the documented file (modelfile), what it says of a
patient (model: Z-scores, task scores, MDC95, real change), fitting one from healthy
controls' assessments (fitting), and the norms a data folder uses (in_use).
docs/norms.md documents the file and the formulas."""

from app.norms.model import (
    SIMULATED_LABEL,
    Change,
    FigureZ,
    NormativeModel,
    NormsError,
    TaskNotPerformed,
    TaskScore,
)
from app.norms.modelfile import FORMAT, FORMAT_VERSION, NormsFileError, load_norms, write_norms
from core.norms.regression import Covariates

__all__ = [
    "FORMAT",
    "FORMAT_VERSION",
    "SIMULATED_LABEL",
    "Change",
    "Covariates",
    "FigureZ",
    "NormativeModel",
    "NormsError",
    "NormsFileError",
    "TaskNotPerformed",
    "TaskScore",
    "load_norms",
    "write_norms",
]
