"""A DeLaN's torque components against the analytic model's, along the samples of a
dynamics data file: the thesis's argument for the DeLaN (section 2.5: it separates the
inertial, Coriolis/centrifugal, potential and dissipative forces) and its Figs. 2.16–2.18
(the pendulum) and 4.5–4.6 (the robot), as a researcher gets them from
`rehab learn components`.

The analytic side is the system's own model: the sliding inverted pendulum of eq. 2.36
for its data (`core.learning.pendulum`: no dissipative term, the data's forces are the
generalised forces), the console's nominal robot (Tables 3.1–3.3, eq. 3.6–3.8) for robot
data: M_R q̈, C_R q̇, the joints' stiffness K_R (θ − θ_R0) in the potential's place (it is
conservative; the planar robot has no gravity), and the friction f_RJ + J_Rᵀ f_RE as the
dissipative term. Robot data recorded on the realistic plant, or with a patient's push
left in the torque, differs from that model by construction: the figure shows where.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import AppError
from app.learning.dataset import Dataset, read_dataset
from app.learning.modelfile import ModelFile, read_model
from app.learning.workflow import ROBOT_SYSTEM_PREFIX, force_units, held_out
from core.learning import inference, pendulum as pd
from core.robot import RobotModel

COMPONENTS = ("inertial", "coriolis", "potential", "dissipative")
TITLES = {"inertial": "inertial H q̈", "coriolis": "Coriolis, centrifugal",
          "potential": "potential ∂V/∂q (gravity, stiffness)",
          "dissipative": "dissipative d(q, q̇) (friction)"}


@dataclass(frozen=True, slots=True, eq=False)
class Components:
    """Each component, learned and analytic, (N, n) over the samples taken; `total` the
    learned model's and `tau` the data's forces."""

    system: str
    forces: tuple[str, ...]
    units: dict[str, str]  # each force's (app.learning.workflow.force_units)
    learned: dict[str, np.ndarray]
    analytic: dict[str, np.ndarray]
    total: np.ndarray
    tau: np.ndarray

    def rmse(self) -> dict[str, np.ndarray]:
        """Each component's RMSE against the analytic one, per force, and the total's
        against the data ('total')."""
        out = {name: np.sqrt(np.mean((self.learned[name] - self.analytic[name]) ** 2, axis=0))
               for name in COMPONENTS}
        out["total"] = np.sqrt(np.mean((self.total - self.tau) ** 2, axis=0))
        return out


def torque_components(model: ModelFile, data: Dataset) -> Components:
    """The components of a DeLaN `model` on `data`; refused in one line for another kind
    of model, or data of a system with no analytic model here."""
    if model.spec["kind"] != "delan":
        raise AppError(f"model {model.name!r} is a {model.spec['kind']}: only a DeLaN "
                       "separates its torque into components; train one with --model delan")
    analytic = analytic_components(data.system, data.q, data.qd, data.qdd)
    terms = inference.delan_terms(model.spec, model.params, data.q, data.qd, data.qdd)
    learned = {"inertial": terms.inertial, "coriolis": terms.coriolis,
               "potential": terms.gravity, "dissipative": terms.dissipative}
    return Components(data.system, data.forces, force_units(data), learned, analytic,
                      terms.total, data.tau)


def components_file(model_path: str | os.PathLike, data_path: str | os.PathLike, *,
                    cycle: int | None = None) -> Components:
    """The components of the model file on the data file's held-out cycles (all of it when
    it marks none), or on one `cycle`; the model checked against the data first."""
    model = read_model(model_path)
    data = read_dataset(data_path)
    model.check_data(data)
    if cycle is not None:
        mask = data.cycle == cycle
        if not mask.any():
            raise AppError(f"{Path(data_path).name} has no cycle {cycle}; its cycles are "
                           f"{int(data.cycle.min())}–{int(data.cycle.max())}")
    else:
        mask = held_out(data)
        if not mask.any():
            mask = np.ones(len(data), bool)
    return torque_components(model, data.select(mask))


def analytic_components(system: str, q, qd, qdd) -> dict[str, np.ndarray]:
    """The system's own model split into COMPONENTS (the module notes say which)."""
    if system == pd.SYSTEM:
        p = pd.Pendulum()
        theta, rate = q[:, 1], qd[:, 1]
        return {"inertial": np.einsum("nij,nj->ni", p.mass_matrix(theta), qdd),
                "coriolis": p.coriolis(theta, rate),
                "potential": p.gravity(theta),
                "dissipative": np.zeros_like(q)}
    if system.startswith(ROBOT_SYSTEM_PREFIX):
        robot = RobotModel()
        return {"inertial": np.einsum("nij,nj->ni", robot.mass_matrix(q), qdd),
                "coriolis": np.einsum("nij,nj->ni", robot.coriolis_matrix(q, qd), qd),
                "potential": np.stack(robot.stiffness_terms(q[:, 0], q[:, 1]), axis=-1),
                "dissipative": robot.friction_torque(q, qd)}
    raise AppError(f"the data's system is {system!r}: its analytic model is not known here "
                   f"(the pendulum's is {pd.SYSTEM!r}, the robot's names begin with "
                   f"{ROBOT_SYSTEM_PREFIX!r})")


def plot_components(c: Components, path: str | os.PathLike, *, title: str = "",
                    overwrite: bool = False) -> Path:
    """One row per component, one column per generalised force, learned (dashed) over
    analytic (solid), against the sample's index; written as a PNG, whole or not at all
    (an existing file replaced only with `overwrite`: app.records.safewrite)."""
    import matplotlib

    from app.records.safewrite import atomic_output

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    n = len(c.forces)
    fig, axes = plt.subplots(len(COMPONENTS), n, figsize=(4.6 * n, 9), sharex=True,
                             squeeze=False)
    x = np.arange(c.tau.shape[0])
    for row, name in enumerate(COMPONENTS):
        for col, force in enumerate(c.forces):
            ax = axes[row, col]
            ax.plot(x, c.analytic[name][:, col], color="black", linewidth=1.0,
                    label="analytic model")
            ax.plot(x, c.learned[name][:, col], color="tab:orange", linestyle="--",
                    linewidth=1.2, label="DeLaN")
            ax.set_title(f"{TITLES[name]}: {force} ({c.units[force]})", fontsize=9)
            ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    for ax in axes[-1]:
        ax.set_xlabel("sample")
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    try:
        with atomic_output(path, overwrite=overwrite) as stream:
            fig.savefig(stream, dpi=110, format="png")
    except OSError as exc:
        raise AppError(f"cannot write {path} ({exc.strerror or exc}); give a folder you can "
                       "write to") from exc
    finally:
        plt.close(fig)
    return path
