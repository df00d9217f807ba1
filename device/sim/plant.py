"""The simulated robot's own physics: the ideal plant (the controller's model exactly) or
a realistic one, drawn from documented ranges around it.

Why: a simulated robot that is its controller's own model tracks 5–10 times better than
the thesis's real robot did (0.9 / 1.4 mm RMS against 8.68 / 7.02 mm in x / y on the D,
section 3.6), and a scheme tuned on it may fail on the robot. The realistic plant keeps
the controller's nominal model (Tables 3.1–3.3 and core.robot's friction) and gives
the simulated robot its own parameters, each drawn uniformly from `SPREAD` by the seed
(the robot's own, device.sim.seeds.ROBOT_SEED, not each trial's):

* **link masses and inertias**, ×0.9–1.1 each: Table 3.3's values come from the CAD
  model; fasteners, cables, belts and the handle's mount are not in it.
* **joint friction**, Coulomb ×1.5–3 and viscous ×1–2.5 of the model's (0.05 N·m and
  0.02 N·m·s/rad): the thesis gives no identified friction, the model's is an
  order-of-magnitude guess (core.robot.Friction), and a belt or cable drive that has
  not been identified usually has more friction than its guess.
* **friction at the handle**, Coulomb 0–0.3 N and viscous 0–1 N·s/m: the handle's
  bearing and a forearm support sliding on the table, which the model leaves out.
* **joint stiffness**, 0–0.1 N·m/rad per joint about the start posture: the cables to
  the motors, encoders and force sensor.
* **drive gain**, ×0.95–1.05 per joint: the motor's torque constant and the
  amplifier's current gain, each within the few percent of a datasheet.
* **actuator delay**: the command acts one loop period (2 ms) after it is written:
  the amplifier's current loop and the transport of the command.

Backlash is left out: the thesis's drives are belt-driven (section 3.1), without gear
teeth. The ideal plant (`Plant.ideal`) stays for the physics tests, which check the
simulator against the very model the controller uses.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from core.errors import ParameterError
from core.robot import Link, RobotModel, Stiffness

PLANTS = ("realistic", "ideal")
"""The simulated plants: the controller's model with documented errors, or the model."""

SPREAD = {
    # quantity: (low, high), uniform
    "link_mass_scale": (0.9, 1.1),
    "link_inertia_scale": (0.9, 1.1),
    "joint_coulomb_scale": (1.5, 3.0),
    "joint_viscous_scale": (1.0, 2.5),
    "handle_coulomb_N": (0.0, 0.3),
    "handle_viscous_Ns_m": (0.0, 1.0),
    "joint_stiffness_Nm_rad": (0.0, 0.1),
    "drive_gain": (0.95, 1.05),
}


@dataclass(frozen=True, slots=True)
class Plant:
    """What the simulator simulates: its robot, whether the drives act a tick late, and
    their gain per joint."""

    robot: RobotModel
    kind: str = "ideal"
    actuator_delay: bool = False
    torque_gain: tuple[float, float] = (1.0, 1.0)

    def __post_init__(self) -> None:
        if self.kind not in PLANTS:
            raise ParameterError("plant", self.kind, "one of " + ", ".join(PLANTS),
                                 "realistic: the robot's own parameters drawn around the "
                                 "model; ideal: the model itself")
        if not isinstance(self.actuator_delay, bool):
            raise ParameterError("actuator_delay", self.actuator_delay, "True or False")
        for i, gain in enumerate(self.torque_gain):
            if not 0.5 <= float(gain) <= 1.5:
                raise ParameterError(f"torque_gain[{i}]", gain, "0.5–1.5",
                                     "the drive's torque per commanded torque")

    @classmethod
    def ideal(cls, robot: RobotModel) -> Plant:
        return cls(robot)

    @classmethod
    def realistic(cls, nominal: RobotModel, seed: int, rest_rad: tuple[float, float]
                  ) -> Plant:
        """`nominal` with every quantity of `SPREAD` drawn by `seed`; the joint stiffness
        rests at `rest_rad` (the start posture)."""
        rng = np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(7,)))

        def draw(name: str, size=None):
            low, high = SPREAD[name]
            return rng.uniform(low, high, size)

        links = tuple(
            Link(link.mass_kg * m, link.inertia_kgm2 * i, link.cg_x_m, link.cg_y_m)
            for link, m, i in zip(nominal.links, draw("link_mass_scale", 4),
                                  draw("link_inertia_scale", 4), strict=True)
        )
        f = nominal.friction
        coulomb = draw("joint_coulomb_scale", 2)
        viscous = draw("joint_viscous_scale", 2)
        friction = replace(
            f,
            joint_coulomb_Nm=tuple(float(v) for v in np.multiply(f.joint_coulomb_Nm, coulomb)),
            joint_viscous_Nms=tuple(float(v) for v in np.multiply(f.joint_viscous_Nms, viscous)),
            ee_coulomb_N=f.ee_coulomb_N + float(draw("handle_coulomb_N")),
            ee_viscous_Ns_m=f.ee_viscous_Ns_m + float(draw("handle_viscous_Ns_m")),
        )
        k = draw("joint_stiffness_Nm_rad", 2)
        stiffness = Stiffness(float(k[0]), 0.0, float(k[1]), *map(float, rest_rad))
        robot = replace(nominal, links=links, friction=friction, stiffness=stiffness)
        gain = draw("drive_gain", 2)
        return cls(robot, "realistic", True, (float(gain[0]), float(gain[1])))

    @classmethod
    def of_kind(cls, kind: str, nominal: RobotModel, seed: int,
                rest_rad: tuple[float, float]) -> Plant:
        if kind == "ideal":
            return cls.ideal(nominal)
        if kind == "realistic":
            return cls.realistic(nominal, seed, rest_rad)
        raise ParameterError("plant", kind, "one of " + ", ".join(PLANTS))

    def describe(self) -> dict:
        """The plant's parameters as plain values, for the trial file."""
        r, f, k = self.robot, self.robot.friction, self.robot.stiffness
        return {
            "kind": self.kind,
            "link_mass_kg": [link.mass_kg for link in r.links],
            "link_inertia_kgm2": [link.inertia_kgm2 for link in r.links],
            "joint_coulomb_Nm": list(f.joint_coulomb_Nm),
            "joint_viscous_Nms": list(f.joint_viscous_Nms),
            "handle_coulomb_N": f.ee_coulomb_N,
            "handle_viscous_Ns_m": f.ee_viscous_Ns_m,
            "joint_stiffness_Nm_rad": [k.k11_Nm_rad, k.k22_Nm_rad],
            "drive_gain": list(self.torque_gain),
            "actuator_delay_periods": 1 if self.actuator_delay else 0,
        }


def plant_summary(described: dict | None) -> dict:
    """A simulated plant (its `Plant.describe()`) as a trial file's summary scalars: its
    kind, and every parameter as JSON (docs/data-format.md, /summary); {} for none (the
    real robot). Headless and live trials write the same, so the norms' covariate robot
    (app.norms.controls.robot_kind) is `simulator-<kind>` for both."""
    if described is None:
        return {}
    import json

    return {"plant": described["kind"], "plant_parameters": json.dumps(described)}
