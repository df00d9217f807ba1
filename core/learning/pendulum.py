"""The sliding inverted pendulum of thesis section 2.5 (eq. 2.36–2.39): the data the thesis
trained its three networks on.

A base of mass M slides on the ground (x1); a slender rod of mass m and length L is hinged
on it (θ2, from the vertical). Generalised coordinates q = (x1, θ2), generalised forces
(f, τ). The rod is driven at a constant speed ω from −45° to 45° (the driving constraint of
eq. 2.37–2.38: θ̈2 = 0), 101 samples a cycle; the base's motion follows from the first row
of eq. 2.36 with f the friction of eq. 2.39, integrated by backward Euler from the cycle's
start at rest (x1 = ẋ1 = 0), as the thesis did; τ is the second row (eq. 2.40).

Eq. 2.39 as printed adds M (kg) to m L/2 cos θ2 (kg·m). We take it as printed, with L its
number in metres: N = g (M + m (L/2) cos θ2). For the thesis's L = 1 m this is the same
number as the dimensionally consistent g (M + (m/2) cos θ2).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from core.errors import ParameterError, check_positive, check_range

G = 9.81  # m/s², as the thesis's ADAMS model
SYSTEM = "sliding-inverted-pendulum"
COORDINATES = ("x1", "theta2")
COORDINATE_UNITS = ("m", "rad")
FORCES = ("f", "tau")
FORCE_UNITS = ("N", "N·m")


@dataclass(frozen=True)
class Pendulum:
    """The thesis's pendulum: M = 1 kg, m = 10 kg, L = 1 m, μ = 0.6 (concrete)."""

    base_mass_kg: float = 1.0      # M
    rod_mass_kg: float = 10.0      # m
    rod_length_m: float = 1.0      # L
    friction_coefficient: float = 0.6  # μ of eq. 2.39

    def __post_init__(self) -> None:
        check_positive("base_mass_kg", self.base_mass_kg, "kg")
        check_positive("rod_mass_kg", self.rod_mass_kg, "kg")
        check_positive("rod_length_m", self.rod_length_m, "m")
        check_range("friction_coefficient", self.friction_coefficient, 0.0, 2.0)

    def description(self) -> dict:
        return {"M_kg": self.base_mass_kg, "m_kg": self.rod_mass_kg,
                "L_m": self.rod_length_m, "mu": self.friction_coefficient, "g_m_s2": G}

    def mass_matrix(self, theta2: np.ndarray) -> np.ndarray:
        """H(q) of eq. 2.36, (..., 2, 2)."""
        M, m, L = self.base_mass_kg, self.rod_mass_kg, self.rod_length_m
        c = m * L / 2.0 * np.cos(theta2)
        H = np.empty((*np.shape(theta2), 2, 2))
        H[..., 0, 0] = m + M
        H[..., 0, 1] = H[..., 1, 0] = c
        H[..., 1, 1] = m * L**2 / 3.0
        return H

    def coriolis(self, theta2: np.ndarray, theta2_dot: np.ndarray) -> np.ndarray:
        """The centrifugal force of eq. 2.36, (..., 2): (−m L/2 θ̇2² sin θ2, 0)."""
        m, L = self.rod_mass_kg, self.rod_length_m
        out = np.zeros((*np.shape(theta2), 2))
        out[..., 0] = -m * L / 2.0 * theta2_dot**2 * np.sin(theta2)
        return out

    def gravity(self, theta2: np.ndarray) -> np.ndarray:
        """The gravitational force of eq. 2.36, (..., 2): (0, −m g L/2 sin θ2)."""
        m, L = self.rod_mass_kg, self.rod_length_m
        out = np.zeros((*np.shape(theta2), 2))
        out[..., 1] = -m * G * L / 2.0 * np.sin(theta2)
        return out

    def friction(self, theta2: np.ndarray) -> np.ndarray:
        """f of eq. 2.39, μ N with N = g (M + m L/2 cos θ2) (the reading in the module's
        docstring), N."""
        M, m, L = self.base_mass_kg, self.rod_mass_kg, self.rod_length_m
        return self.friction_coefficient * G * (M + m * L / 2.0 * np.cos(theta2))

    def generalised_forces(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """The left side of eq. 2.36, H q̈ + c + g, (..., 2): (f, τ) for any motion."""
        theta2 = q[..., 1]
        H = self.mass_matrix(theta2)
        return (np.einsum("...ij,...j->...i", H, qdd) + self.coriolis(theta2, qd[..., 1])
                + self.gravity(theta2))


@dataclass(frozen=True)
class PendulumData:
    """Samples of the pendulum: q, q̇, q̈, (f, τ), each (N, 2), and the cycle of each (N,)."""

    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    cycle: np.ndarray
    speeds_rad_s: np.ndarray  # the rod's speed in each cycle, (cycles,)


# 1,000 cycles at 1 + k/111 rad/s, k = 0 … 999: 1 … 10 rad/s, 5 rad/s exactly (k = 444).
# The thesis does not give its speeds. Slower sweeps last long enough for the friction
# force of eq. 2.39, pushing the base all the while, to drive it to tens of m/s (hundreds
# below 0.1 rad/s): no pendulum anyone would build, and an ill-posed data set.
THESIS_SPEEDS_RAD_S = 1.0 + np.arange(1000) / 111.0
HELD_OUT_SPEED_RAD_S = 5.0                       # Table 2.1's test cycle
SAMPLES_PER_CYCLE = 101


MAX_BASE_SPEED_M_S = 10.0
"""The fastest the base may slide in a cycle. Eq. 2.39's friction pushes the base the
whole sweep, so a slow sweep drives it ever faster (46 m/s and 370 m of track at 0.1
rad/s), and the rod's swing flings it at a fast one (13 m/s at 100 rad/s, 130 at 1,000,
with 330 g on the base and 11 kN·m on the rod): no pendulum on a track moves so, and a
data set of such cycles teaches a model nothing of the thesis's pendulum. The thesis's
1 … 10 rad/s keep the base under 5 m/s."""


def generate(speeds_rad_s=THESIS_SPEEDS_RAD_S, pendulum: Pendulum | None = None,
             samples_per_cycle: int = SAMPLES_PER_CYCLE, first_cycle: int = 0) -> PendulumData:
    """One cycle per speed: the rod driven at ω from −45° to 45° (eq. 2.37–2.38), the base's
    acceleration from the first row of eq. 2.36 with f of eq. 2.39, its rate and position by
    backward Euler from rest, τ from the second row (eq. 2.40). 1,000 speeds of 1 … 10
    rad/s (the default) give the thesis's 101,000 samples, the 5 rad/s cycle among them.
    A speed whose cycle slides the base faster than MAX_BASE_SPEED_M_S is refused
    (`speed_refusal` says why, `speed_limits` which speeds may be given)."""
    pendulum = pendulum or Pendulum()
    data = _cycles(speeds_rad_s, pendulum, samples_per_cycle, first_cycle)
    fast = ~(base_top_speeds(data) <= MAX_BASE_SPEED_M_S)  # NaN: beyond float's range
    if np.any(fast):
        k = int(np.argmax(fast))
        raise ParameterError("speeds_rad_s", float(data.speeds_rad_s[k]),
                             _speeds_allowed(pendulum),
                             _too_fast(float(data.speeds_rad_s[k]),
                                       float(base_top_speeds(data)[k])))
    return data


def base_top_speeds(data: PendulumData) -> np.ndarray:
    """Each cycle's fastest slide of the base, |ẋ1| (m/s), (cycles,)."""
    per_cycle = np.abs(data.qd[:, 0]).reshape(data.speeds_rad_s.size, -1)
    return per_cycle.max(axis=1)


def speed_refusal(speed_rad_s: float, pendulum: Pendulum | None = None) -> str:
    """Why the rod cannot be driven at `speed_rad_s` for a cycle ("" if it can)."""
    top = float(base_top_speeds(_cycles([speed_rad_s], pendulum or Pendulum()))[0])
    if top <= MAX_BASE_SPEED_M_S:  # NaN (beyond float's range) is refused
        return ""
    return (f"{_too_fast(speed_rad_s, top)}; give speeds from "
            f"{_speeds_allowed(pendulum or Pendulum())}")


def speed_limits(pendulum: Pendulum | None = None) -> tuple[float, float]:
    """The slowest and fastest rod speeds (rad/s) whose cycle keeps the base within
    MAX_BASE_SPEED_M_S: its top speed falls as the friction's push gets less time, then
    rises as the swing flings it, so each limit is found by bisection on its side of the
    gentlest speed."""
    pendulum = pendulum or Pendulum()

    def top(speed: float) -> float:
        return float(base_top_speeds(_cycles([speed], pendulum))[0])

    grid = np.geomspace(1e-3, 1e4, 141)
    gentlest = float(grid[int(np.argmin([top(w) for w in grid]))])

    def edge(inside: float, outside: float) -> float:
        for _ in range(60):
            middle = math.sqrt(inside * outside)
            inside, outside = (middle, outside) if top(middle) <= MAX_BASE_SPEED_M_S else (
                inside, middle)
        return inside

    return edge(gentlest, 1e-3), edge(gentlest, 1e4)


def _too_fast(speed_rad_s: float, top_m_s: float) -> str:
    top = f"{top_m_s:.3g} m/s" if math.isfinite(top_m_s) else "more m/s than a number holds"
    return (f"at {speed_rad_s:g} rad/s the base would slide at {top} "
            f"(eq. 2.36 with eq. 2.39's friction), over the {MAX_BASE_SPEED_M_S:g} m/s "
            "a pendulum on a track can")


def _speeds_allowed(pendulum: Pendulum) -> str:
    low, high = speed_limits(pendulum)
    # rounded inwards, so that the speeds the line names are themselves allowed
    return (f"{math.ceil(low * 100) / 100:g} to {math.floor(high * 10) / 10:g} rad/s "
            "(the thesis's: 1 to 10)")


def _cycles(speeds_rad_s, pendulum: Pendulum, samples_per_cycle: int = SAMPLES_PER_CYCLE,
            first_cycle: int = 0) -> PendulumData:
    """generate's cycles, whatever the base's speed."""
    speeds = np.asarray(speeds_rad_s, dtype=float).reshape(-1)
    if speeds.size == 0 or not np.all(np.isfinite(speeds)) or np.any(speeds <= 0.0):
        raise ValueError("the rod's speeds must be finite and > 0 rad/s")
    n = int(samples_per_cycle)
    if n < 2:
        raise ValueError("a cycle needs at least 2 samples")
    # a speed beyond float's range gives inf and NaN, which generate then refuses
    with np.errstate(over="ignore", invalid="ignore"):
        return _integrated(speeds, pendulum, n, first_cycle)


def _integrated(speeds: np.ndarray, pendulum: Pendulum, n: int,
                first_cycle: int) -> PendulumData:
    M, m, L = pendulum.base_mass_kg, pendulum.rod_mass_kg, pendulum.rod_length_m
    sweep = np.pi / 2.0
    theta2 = -np.pi / 4.0 + np.linspace(0.0, sweep, n)              # (n,)
    omega = speeds[:, None] * np.ones(n)                             # (cycles, n)
    h = sweep / (n - 1) / speeds                                     # each cycle's time step
    f = pendulum.friction(theta2) * np.ones_like(omega)
    # first row of eq. 2.36 with θ̈2 = 0: (m + M) ẍ1 − m L/2 ω² sin θ2 = f
    x1_dd = (f + m * L / 2.0 * omega**2 * np.sin(theta2)) / (m + M)
    # backward Euler from rest: ẋ1[k] = ẋ1[k−1] + h ẍ1[k], x1[k] = x1[k−1] + h ẋ1[k]
    step = x1_dd.copy()
    step[:, 0] = 0.0
    x1_d = np.cumsum(step * h[:, None], axis=1)
    x1_step = x1_d.copy()
    x1_step[:, 0] = 0.0
    x1 = np.cumsum(x1_step * h[:, None], axis=1)
    q = np.stack([x1, np.broadcast_to(theta2, x1.shape)], axis=-1).reshape(-1, 2)
    qd = np.stack([x1_d, omega], axis=-1).reshape(-1, 2)
    qdd = np.stack([x1_dd, np.zeros_like(x1_dd)], axis=-1).reshape(-1, 2)
    # τ from the second row (eq. 2.40); f as eq. 2.39 gave it
    tau_rod = (m * L / 2.0 * np.cos(theta2) * x1_dd
               - m * G * L / 2.0 * np.sin(theta2)).reshape(-1)
    forces = np.stack([f.reshape(-1), tau_rod], axis=-1)
    cycle = np.repeat(np.arange(first_cycle, first_cycle + speeds.size), n)
    return PendulumData(q=q, qd=qd, qdd=qdd, tau=forces, cycle=cycle,
                        speeds_rad_s=speeds.copy())


def held_out_mask(data: PendulumData, speed_rad_s: float = HELD_OUT_SPEED_RAD_S) -> np.ndarray:
    """True for the samples of the cycle at `speed_rad_s` (Table 2.1's test cycle)."""
    index = int(np.argmin(np.abs(data.speeds_rad_s - speed_rad_s)))
    if not np.isclose(data.speeds_rad_s[index], speed_rad_s, rtol=0.0, atol=1e-9):
        raise ValueError(f"no cycle at {speed_rad_s} rad/s")
    return data.cycle == data.cycle[0] + index
