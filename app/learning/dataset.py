"""A dynamics data set: one HDF5 file of generalised coordinates, their rates and
accelerations, and the generalised forces (docs/data-format.md, "Dynamics data").

Datasets `q`, `qd`, `qdd`, `tau`, each (N, n) float64 in SI units; `cycle` (N,) numbering
the cycles (a pendulum's sweep, a robot's trial); root attributes `system` (what produced
the data), `coordinates` and `forces` (their names), `format`, `format_version`. Any file
in this layout can be read, a researcher's own data included; anything else is refused
with one line that says what is wrong.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.errors import AppError

FORMAT = "rehab-console-dynamics"
FORMAT_VERSION = 1
ARRAYS = ("q", "qd", "qdd", "tau")


class DatasetError(AppError):
    """A dynamics data file cannot be read or written."""

    def __init__(self, path: object, problem: str, advice: str) -> None:
        self.path, self.problem, self.advice = path, problem, advice
        super().__init__(f"dynamics data {path}: {problem}. {advice}")


@dataclass(frozen=True)
class Dataset:
    """Samples of a mechanical system with n generalised coordinates."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    cycle: np.ndarray
    system: str
    coordinates: tuple[str, ...]
    forces: tuple[str, ...]
    description: dict = field(default_factory=dict)

    @property
    def dof(self) -> int:
        return self.q.shape[1]

    def __len__(self) -> int:
        return self.q.shape[0]

    def select(self, mask: np.ndarray) -> Dataset:
        """The samples where `mask` is true (whole cycles, for a recurrent model)."""
        return Dataset(self.q[mask], self.qd[mask], self.qdd[mask], self.tau[mask],
                       self.cycle[mask], self.system, self.coordinates, self.forces,
                       self.description)

    def summary(self) -> dict:
        """What a model file records of the data it learned from."""
        return {"system": self.system, "samples": len(self), "dof": self.dof,
                "cycles": int(np.unique(self.cycle).size),
                "coordinates": list(self.coordinates), "forces": list(self.forces),
                "description": self.description}


def write_dataset(path: str | Path, data: Dataset, *, overwrite: bool = False,
                  owned: bool = False) -> Path:
    """Write `data` to `path`, whole or not at all (app.records.safewrite: an existing file
    only with `overwrite`, never what a data folder owns unless `owned`)."""
    import h5py

    from app.records.safewrite import OutputRefused, atomic_path

    path = Path(path)
    _check_consistent(path, data.q, data.qd, data.qdd, data.tau, data.cycle)
    try:
        with atomic_path(path, overwrite=overwrite, owned=owned) as temporary, \
                h5py.File(temporary, "w") as f:
            for name in ARRAYS:
                f.create_dataset(name, data=np.asarray(getattr(data, name), dtype=np.float64))
            f.create_dataset("cycle", data=np.asarray(data.cycle, dtype=np.int64))
            f.attrs["format"] = FORMAT
            f.attrs["format_version"] = np.int64(FORMAT_VERSION)
            f.attrs["system"] = data.system
            f.attrs["coordinates"] = json.dumps(list(data.coordinates))
            f.attrs["forces"] = json.dumps(list(data.forces))
            f.attrs["description"] = json.dumps(data.description)
    except (OSError, OutputRefused) as exc:
        raise DatasetError(path, f"cannot be written ({exc})",
                           "Choose another file, or a folder you can write to.") from None
    return path


def read_dataset(path: str | Path) -> Dataset:
    """Read a dynamics data file; refuse a missing, damaged or malformed one by its fault."""
    import h5py

    path = Path(path)
    if path.is_dir():
        raise DatasetError(path, "is a folder", "Give the dynamics data file (.h5) in it.")
    if not path.is_file():
        raise DatasetError(path, "no such file", "Check the path, or make one with "
                           "`rehab learn pendulum --output FILE`.")
    try:
        f = h5py.File(path, "r")
    except OSError:
        raise DatasetError(path, "is not an HDF5 file", "Give a file in the dynamics data "
                           "format (docs/data-format.md).") from None
    with f:
        missing = [name for name in (*ARRAYS, "cycle") if name not in f]
        if missing:
            raise DatasetError(path, f"has no dataset {', '.join(missing)}",
                               "A dynamics file holds q, qd, qdd, tau and cycle "
                               "(docs/data-format.md).")
        if "system" not in f.attrs:
            raise DatasetError(path, "has no 'system' attribute",
                               "Name the system that produced the data in a root attribute "
                               "'system'.")
        version = f.attrs.get("format_version", FORMAT_VERSION)
        if int(version) > FORMAT_VERSION:
            raise DatasetError(path, f"is format version {int(version)}, newer than this "
                               f"console's {FORMAT_VERSION}", "Update the console.")
        arrays = {}
        for name in (*ARRAYS, "cycle"):
            dataset = f[name]
            if not isinstance(dataset, h5py.Dataset) or dataset.dtype.kind not in "fiu":
                raise DatasetError(path, f"'{name}' is not a numeric dataset",
                                   "Store q, qd, qdd, tau as float64 and cycle as integers.")
            arrays[name] = dataset[()]
        system = _text(f.attrs["system"])
        description = _json(path, f.attrs, "description", {})
        coordinates = _json(path, f.attrs, "coordinates", None)
        forces = _json(path, f.attrs, "forces", None)
    q, qd, qdd, tau, cycle = (arrays[n] for n in (*ARRAYS, "cycle"))
    _check_consistent(path, q, qd, qdd, tau, cycle)
    n = q.shape[1]
    coordinates = tuple(coordinates) if coordinates else tuple(f"q{i + 1}" for i in range(n))
    forces = tuple(forces) if forces else tuple(f"tau{i + 1}" for i in range(n))
    if len(coordinates) != n or len(forces) != n:
        raise DatasetError(path, f"names {len(coordinates)} coordinates and {len(forces)} "
                           f"forces for {n} columns", "Give one name per column.")
    return Dataset(q.astype(np.float64), qd.astype(np.float64), qdd.astype(np.float64),
                   tau.astype(np.float64), cycle.astype(np.int64), system,
                   coordinates, forces, description)


def _check_consistent(path, q, qd, qdd, tau, cycle) -> None:
    arrays = {"q": np.asarray(q), "qd": np.asarray(qd), "qdd": np.asarray(qdd),
              "tau": np.asarray(tau)}
    shape = arrays["q"].shape
    if len(shape) != 2 or shape[0] < 1 or shape[1] < 1:
        raise DatasetError(path, f"'q' has shape {shape}, not (N, n)",
                           "Store one row per sample, one column per coordinate.")
    for name, array in arrays.items():
        if array.shape != shape:
            raise DatasetError(path, f"'{name}' has shape {array.shape}, 'q' has {shape}",
                               "Every one of q, qd, qdd, tau has one row per sample and one "
                               "column per coordinate.")
        if not np.all(np.isfinite(array)):
            raise DatasetError(path, f"'{name}' holds NaN or infinite values",
                               "Remove or fill those samples.")
    if np.asarray(cycle).shape != (shape[0],):
        raise DatasetError(path, f"'cycle' has shape {np.asarray(cycle).shape}, not "
                           f"({shape[0]},)", "Number each sample's cycle (trial, sweep).")


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)


def _json(path, attrs, name, default):
    if name not in attrs:
        return default
    try:
        return json.loads(_text(attrs[name]))
    except ValueError:
        raise DatasetError(path, f"attribute '{name}' is not JSON",
                           "Write it as JSON (docs/data-format.md).") from None


def pendulum_dataset(data, pendulum) -> Dataset:
    """The pendulum's samples (core.learning.pendulum) as a data set."""
    from core.learning import pendulum as p

    description = {"pendulum": pendulum.description(),
                   "cycle_speeds_rad_s": [float(s) for s in data.speeds_rad_s],
                   "samples_per_cycle": int(len(data.cycle) // len(data.speeds_rad_s)),
                   "first_cycle": int(data.cycle[0])}
    return Dataset(data.q, data.qd, data.qdd, data.tau, data.cycle, p.SYSTEM,
                   p.COORDINATES, p.FORCES, description)
