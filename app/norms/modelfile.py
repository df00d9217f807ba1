"""The normative-model file: one JSON document a clinic, a study or this console writes
(docs/norms.md, "The file"), read with every field verified.

A file is refused in one line naming the file, the field and what to do when it is not
JSON, not of this format, of a newer version, does not match its content SHA-256 (when it
carries one: a hand-written file need not), lacks a field or has one it does not know (a
misspelt `mdc_95` would otherwise be silently ignored), holds a number that is not finite
or out of its range, a transform that is not defined on its own shift, a Box-Cox shift
beyond ±MAX_SHIFT or one that leaves values the figure (or a task's distance, from 0) can
take outside its domain (a negative shift on a non-negative figure), a λ on a transform
'none', coefficients that are not exactly the covariates' columns, or a task combining a
figure it does not hold.
Figures are checked against core.assessment.FIGURES: a key the console does not measure
is refused, and so is a `worse` side that contradicts the figure's `better`.
"""

from __future__ import annotations

import hashlib
import json
import math
from collections.abc import Mapping
from pathlib import Path

from app.errors import AppError
from app.norms.model import FigureNorm, NormativeModel, TaskNorm
from core.errors import CoreError
from core.norms.regression import AGE, CATEGORICAL, CovariateSpec, Regression
from core.norms.scores import BETTER_TO_WORSE, WORSE
from core.norms.transforms import KINDS, Transform

FORMAT = "rehab-console-norms"
FORMAT_VERSION = 1
MAX_BYTES = 16 * 2**20
"""A norms file is a few kilobytes per figure; anything above this is not one."""
MAX_NUMBER = 1e12
MAX_SHIFT = 1e3
"""The largest Box-Cox shift (either sign) a file may hold, in the figure's SI unit. A shift
moves a figure's values above 0; no figure this console measures (an LDLJ of −30, a force
of 100 N, a time of 60 s) nor a task's distance needs 10³ for that. Far beyond, Box-Cox is
a straight line in disguise (t ≈ s^(λ−1)·x), and at the 10¹² the file's numbers allowed
before, x + s keeps a speed of 0.1 m/s to 10⁻⁴ only."""
TOP_KEYS = {"format", "format_version", "source", "simulated", "created_utc", "covariates",
            "figures", "tasks", "calibration", "notes", "content_sha256"}
REQUIRED_TOP = {"format", "format_version", "source", "simulated", "covariates", "figures",
                "tasks"}
FIGURE_KEYS = {"transform", "coefficients", "residual_sd", "n", "worse", "mdc95", "icc"}
REQUIRED_FIGURE = {"transform", "coefficients", "residual_sd", "n", "worse"}
TASK_KEYS = {"figures", "transform", "mean", "sd", "n", "mdc95", "icc"}
REQUIRED_TASK = {"figures", "transform", "mean", "sd", "n"}
TRANSFORM_KEYS = {"kind", "lambda", "shift"}
WRITTEN_BY = "`rehab norms fit`"


class NormsFileError(AppError):
    """A norms file cannot be used; the message is its one line."""

    def __init__(self, path: object, problem: str,
                 advice: str = f"Give a norms file written by {WRITTEN_BY} or as "
                               "docs/norms.md describes.") -> None:
        self.path, self.problem = path, problem
        super().__init__(f"norms file {path}: {problem}." + (f" {advice}" if advice else ""))


def member(parent: str, key: str) -> str:
    """Where a key of the file is, for a message: `parent.key`, or `parent['…']` (Python's
    escapes, at most 40 characters of it) for a key a line cannot show as it is (a newline
    in a figure's name made the refusal two lines: the fuzz test of this module)."""
    if key.isprintable() and key.strip() == key and 0 < len(key) <= 60:
        return f"{parent}.{key}"
    return f"{parent}[{key[:40]!r}{'…' if len(key) > 40 else ''}]"


def content_hash(document: Mapping) -> str:
    """SHA-256 of the document without its hash, keys sorted, no spaces."""
    body = {k: v for k, v in document.items() if k != "content_sha256"}
    text = json.dumps(body, sort_keys=True, separators=(",", ":"), allow_nan=False)
    return hashlib.sha256(text.encode()).hexdigest()


def _no_constant(name: str):
    raise ValueError(f"{name} is not a number JSON allows")


def load_norms(path: str | Path) -> NormativeModel:
    """Read and verify a norms file; NormsFileError in one line otherwise."""
    from device.safeinput import InputRefused, check_file

    path = Path(path)
    try:
        check_file(path, what="norms file")
    except InputRefused as exc:
        if "does not exist" in exc.problem:
            raise NormsFileError(path, "no such file", "Check the path.") from None
        # the refusal says what to give already ("is a folder: give a file")
        problem = exc.problem.rstrip(".")
        raise NormsFileError(path, problem, "" if "give" in problem else "Give the file.") \
            from None
    try:
        if path.stat().st_size > MAX_BYTES:
            raise ValueError("too large")
        document = json.loads(path.read_bytes().decode("utf-8"), parse_constant=_no_constant)
    except (ValueError, UnicodeDecodeError, RecursionError):
        raise NormsFileError(path, "is not a JSON norms file") from None
    except OSError as exc:
        raise NormsFileError(path, f"cannot be read ({exc.strerror or exc})",
                             "Check the file's permissions.") from None
    return parse_norms(document, path)


def parse_norms(document: object, path: object = "<document>") -> NormativeModel:
    """The model a norms document describes, verified field by field."""
    reader = _Reader(path)
    if not isinstance(document, dict) or document.get("format") != FORMAT:
        raise NormsFileError(path, f"is not a norms file of this console (its 'format' "
                             f"must be {FORMAT!r})")
    version = document.get("format_version")
    if isinstance(version, bool) or not isinstance(version, int) or version < 1:
        raise NormsFileError(path, f"format_version {str(version)[:20]!r} is not a whole "
                             "number from 1")
    if version > FORMAT_VERSION:
        raise NormsFileError(path, f"is format version {version}, newer than this "
                             f"console's {FORMAT_VERSION}", "Update the console.")
    if "content_sha256" in document and document["content_sha256"] != content_hash(document):
        raise NormsFileError(path, "its content does not match its content_sha256 (edited "
                             "or damaged)", "Use the file as it was written, or remove "
                             "content_sha256 if you edited it on purpose.")
    reader.keys("the file", document, TOP_KEYS, REQUIRED_TOP)
    source = document["source"]
    if not isinstance(source, str) or not source.strip() or len(source) > 500:
        raise NormsFileError(path, "'source' must say who made the norms, from which "
                             "people, when (1 to 500 characters)")
    simulated = document["simulated"]
    if not isinstance(simulated, bool):
        raise NormsFileError(path, "'simulated' must be true or false")
    spec = reader.covariates(document["covariates"])
    figures = reader.figures(document["figures"], spec)
    tasks = reader.tasks(document["tasks"], figures)
    notes = document.get("notes", "")
    if not isinstance(notes, str) or len(notes) > 5000:
        raise NormsFileError(path, "'notes' must be text (at most 5000 characters)")
    calibration = document.get("calibration", {})
    if not isinstance(calibration, dict):
        raise NormsFileError(path, "'calibration' must be an object")
    return NormativeModel(source.strip(), simulated, spec, figures, tasks,
                          document.get("content_sha256") or content_hash(document),
                          calibration, path, notes)


class _Reader:
    """The checks of one document, each refusal naming the field."""

    def __init__(self, path: object) -> None:
        self.path = path

    def fail(self, where: str, problem: str) -> NormsFileError:
        return NormsFileError(self.path, f"{where}: {problem}")

    def keys(self, where: str, value: object, allowed: set, required: set) -> dict:
        if not isinstance(value, dict):
            raise self.fail(where, "must be an object")
        unknown = sorted(set(value) - allowed)
        if unknown:
            raise self.fail(where, f"has {unknown[0]!r}, which norms files do not have "
                            f"(allowed: {', '.join(sorted(allowed))})")
        missing = sorted(required - set(value))
        if missing:
            raise self.fail(where, f"lacks {missing[0]!r}")
        return value

    def number(self, where: str, value: object, *, low: float = -MAX_NUMBER,
               high: float = MAX_NUMBER, positive: bool = False) -> float:
        bound = "more than 0" if positive else f"from {low:g} to {high:g}"
        refused = self.fail(where, f"{str(value)[:30]!r} is not a finite number {bound}")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise refused
        try:
            number = float(value)  # an integer of 400 digits overflows here
        except OverflowError:
            raise refused from None
        if not math.isfinite(number) or not low <= number <= high or (
                positive and number <= 0):
            raise refused
        return number

    def whole(self, where: str, value: object, low: int) -> int:
        if isinstance(value, bool) or not isinstance(value, int) or value < low:
            raise self.fail(where, f"{str(value)[:30]!r} is not a whole number from {low}")
        return value

    def covariates(self, value: object) -> CovariateSpec:
        block = self.keys("covariates", value, {AGE, *CATEGORICAL}, {AGE, *CATEGORICAL})
        ages = block[AGE]
        if not isinstance(ages, list) or len(ages) != 2:
            raise self.fail(f"covariates.{AGE}", "must be the controls' [youngest, oldest] "
                            "age in years")
        low = self.number(f"covariates.{AGE}[0]", ages[0], low=0, high=130)
        high = self.number(f"covariates.{AGE}[1]", ages[1], low=low, high=130)
        levels = {}
        for name in CATEGORICAL:
            found = block[name]
            if not isinstance(found, list) or not all(isinstance(v, str) for v in found):
                raise self.fail(f"covariates.{name}", "must be a list of the levels the "
                                "controls had, the reference first")
            levels[name] = tuple(found)
        try:
            return CovariateSpec((low, high), levels)
        except CoreError as exc:
            raise self.fail("covariates", str(exc)) from None

    def transform(self, where: str, value: object, lowest: float, of: str) -> Transform:
        """`lowest`: the least value the transformed quantity can take by its definition
        (-inf when unbounded), `of` what it is, for the message: a Box-Cox shift must keep
        every value above it in x + shift > 0."""
        block = self.keys(where, value, TRANSFORM_KEYS, {"kind"})
        kind = block["kind"]
        if kind not in KINDS:
            raise self.fail(f"{where}.kind", f"{str(kind)[:30]!r} is not one of "
                            f"{', '.join(KINDS)}")
        lam = self.number(f"{where}.lambda", block.get("lambda", 1.0), low=-10, high=10)
        if kind == "none" and lam != 1.0:
            raise self.fail(f"{where}.lambda", f"{lam:g} on a transform 'none', which has "
                            "no λ (1 or absent)")
        shift = self.number(f"{where}.shift", block.get("shift", 0.0))
        if abs(shift) > MAX_SHIFT:
            raise self.fail(f"{where}.shift", f"{shift:g} is beyond ±{MAX_SHIFT:g}, further "
                            f"than {of} ever need moving to be above 0; refit the norms "
                            "(`rehab norms fit`) or give the shift that puts the least of "
                            "them just above 0")
        if kind == "box-cox" and math.isfinite(lowest) and lowest + shift < 0.0:
            # the values in (lowest, −shift] could never be scored: for a task's distance
            # those are the best scores (a healthy person's), for a figure a patient's
            raise self.fail(f"{where}.shift", f"{shift:g} leaves {of} from {lowest:g} to "
                            f"{-shift:g} outside Box-Cox's domain (x + shift > 0): no "
                            f"Z-score for them; give a shift of at least {0.0 - lowest:g}")
        try:
            return Transform(kind, lam, shift)
        except CoreError as exc:
            raise self.fail(where, str(exc)) from None

    def mdc_icc(self, where: str, block: dict) -> tuple[float | None, float | None]:
        """A figure's or task's optional MDC95 (≥ 0) and ICC (−1 to 1): the ICC was read
        and dropped before, so nothing could say that an MDC95 rests on no reliability."""
        mdc, icc = block.get("mdc95"), block.get("icc")
        if mdc is not None:
            mdc = self.number(f"{where}.mdc95", mdc, low=0)
        if icc is not None:
            icc = self.number(f"{where}.icc", icc, low=-1, high=1)
        return mdc, icc

    def figures(self, value: object, spec: CovariateSpec) -> dict[str, FigureNorm]:
        if not isinstance(value, dict) or not value:
            raise self.fail("figures", "must be an object with at least one figure")
        catalogue = _catalogue()
        out = {}
        for key, block in value.items():
            where = member("figures", key)
            if key not in catalogue:
                raise self.fail(where, "is not a figure this console measures "
                                "(core.assessment.FIGURES; docs/assessments.md)")
            self.keys(where, block, FIGURE_KEYS, REQUIRED_FIGURE)
            transform = self.transform(f"{where}.transform", block["transform"],
                                       _lowest(key), "values the figure can take")
            coefficients = self.keys(f"{where}.coefficients", block["coefficients"],
                                     set(spec.columns), set(spec.columns))
            beta = {c: self.number(f"{where}.coefficients.{c}", coefficients[c])
                    for c in spec.columns}
            sd = self.number(f"{where}.residual_sd", block["residual_sd"], positive=True)
            n = self.whole(f"{where}.n", block["n"], len(spec.columns) + 2)
            worse = block["worse"]
            expected = BETTER_TO_WORSE[catalogue[key]]
            if worse not in WORSE:
                raise self.fail(f"{where}.worse", f"{str(worse)[:30]!r} is not one of "
                                f"{', '.join(WORSE)}")
            if worse != expected:
                raise self.fail(f"{where}.worse", f"{worse!r} contradicts the figure, which "
                                f"is worse {'either way' if expected == 'both' else expected}")
            mdc, icc = self.mdc_icc(where, block)
            out[key] = FigureNorm(transform, Regression(beta, sd, n), worse, mdc, icc)
        return out

    def tasks(self, value: object, figures: Mapping[str, FigureNorm]) -> dict[str, TaskNorm]:
        if not isinstance(value, dict):
            raise self.fail("tasks", "must be an object (it may be empty)")
        from core.assessment import TASKS

        out = {}
        for task, block in value.items():
            where = member("tasks", task)
            if task not in TASKS:
                raise self.fail(where, f"is not a task of this console ({', '.join(TASKS)})")
            self.keys(where, block, TASK_KEYS, REQUIRED_TASK)
            names = block["figures"]
            if not isinstance(names, list) or not names or len(set(map(str, names))) != len(
                    names) or not all(isinstance(n, str) for n in names):
                raise self.fail(f"{where}.figures", "must list the figures it combines, "
                                "at least one, none twice")
            absent = [n for n in names if n not in figures]
            if absent:
                raise self.fail(f"{where}.figures", f"combines {absent[0]!r}, which the "
                                "file's figures do not hold")
            transform = self.transform(f"{where}.transform", block["transform"], 0.0,
                                       "the task's distances (eq. 3; the least are the best)")
            mean = self.number(f"{where}.mean", block["mean"])
            sd = self.number(f"{where}.sd", block["sd"], positive=True)
            n = self.whole(f"{where}.n", block["n"], 3)
            mdc, icc = self.mdc_icc(where, block)
            out[task] = TaskNorm(tuple(names), transform, mean, sd, n, mdc, icc)
        return out


def _catalogue() -> dict[str, str]:
    """Each figure key the console measures, with its `better` side."""
    from core.assessment import FIGURES

    return {spec.key: spec.better for spec in _specs(FIGURES)}


def _lowest(key: str) -> float:
    """The least value figure `key` can take by its definition (core.assessment.figures
    .domain; -inf where unbounded)."""
    from core.assessment.figures import domain

    return domain(key)[0]


def _specs(figures):
    return figures.values() if isinstance(figures, Mapping) else figures


def norms_document(model_document: dict) -> dict:
    """The document with its content_sha256 set (the writer's last step)."""
    document = {k: v for k, v in model_document.items() if k != "content_sha256"}
    document["content_sha256"] = content_hash(document)
    return document


def write_norms(path: str | Path, document: dict, *, overwrite: bool = False,
                owned: bool = False) -> Path:
    """Write a norms document, checked first (parse_norms), with its hash, whole or not at
    all (app.records.safewrite): never over a file unless `overwrite`, never into a data
    folder's own files unless `owned`."""
    from app.records.safewrite import OutputRefused, write_text

    path = Path(path)
    document = norms_document(document)
    parse_norms(document, path)
    try:
        write_text(path, json.dumps(document, indent=1, allow_nan=False) + "\n",
                   overwrite=overwrite, owned=owned)
    except OutputRefused as exc:
        raise NormsFileError(path, str(exc), "Choose another file.") from None
    return path
