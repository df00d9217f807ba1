"""Desired paths and their timing: the thesis's D (section 3.6, Fig. A.7) and the
exercises a clinic expects beside it.

A *path* is a chain of straight lines and circular arcs, walked by arc length s.
A *trajectory* puts a timing law on a path: constant path speed (as in the
thesis: the D's corners then ask for a jump in velocity) or a minimum-jerk
profile per segment (rest at every corner, bounded acceleration). Repetitions
walk the path again; after the last one the target rests at the start point.

Every evaluation is vectorised over an array of times (`sample`), and `at`
evaluates one time with plain floats for the 2 ms tick. Positions, velocities
and accelerations are in the robot's global frame (m, m/s, m/s²); the joint-space
reference comes from the robot's inverse kinematics (`joint_reference`).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from core.arrays import joint_motion
from core.errors import ParameterError, check_positive, check_range
from core.robot import RobotModel

SHAPES = ("d", "circle", "reach", "targets", "figure8")
TIMINGS = ("constant_speed", "minimum_jerk")


@dataclass(frozen=True, slots=True)
class Line:
    """A straight segment from `start` to `end` (m)."""

    start: tuple[float, float]
    end: tuple[float, float]

    @property
    def length(self) -> float:
        return math.hypot(self.end[0] - self.start[0], self.end[1] - self.start[1])

    def geometry(self, s):
        """Position, unit tangent and curvature vector (d²p/ds²) at arc length s."""
        ux = (self.end[0] - self.start[0]) / self.length
        uy = (self.end[1] - self.start[1]) / self.length
        zero = 0.0 * s
        return (self.start[0] + ux * s, self.start[1] + uy * s, ux + zero, uy + zero, zero, zero)


@dataclass(frozen=True, slots=True)
class Arc:
    """A circular arc about `centre` of `radius`, from `start_rad`, sweeping
    `sweep_rad` (positive counter-clockwise)."""

    centre: tuple[float, float]
    radius: float
    start_rad: float
    sweep_rad: float

    @property
    def length(self) -> float:
        return self.radius * abs(self.sweep_rad)

    def geometry(self, s):
        xp = np if isinstance(s, np.ndarray) else math
        sign = 1.0 if self.sweep_rad > 0 else -1.0
        phi = self.start_rad + sign * s / self.radius
        c, si = xp.cos(phi), xp.sin(phi)
        return (
            self.centre[0] + self.radius * c,
            self.centre[1] + self.radius * si,
            -sign * si,
            sign * c,
            -c / self.radius,
            -si / self.radius,
        )


Segment = Line | Arc


@dataclass(frozen=True, slots=True)
class Path:
    """A chain of segments walked end to end."""

    segments: tuple[Segment, ...]

    def __post_init__(self) -> None:
        if not self.segments:
            raise ParameterError("segments", 0, "at least one segment")

    @property
    def lengths(self) -> np.ndarray:
        return np.array([seg.length for seg in self.segments])

    @property
    def length(self) -> float:
        return float(self.lengths.sum())

    def points(self, spacing_m: float = 0.002) -> np.ndarray:
        """Points along the whole path, at most `spacing_m` apart, shape (N, 2)."""
        chunks = []
        for seg in self.segments:
            n = max(2, math.ceil(seg.length / spacing_m) + 1)
            x, y, *_ = seg.geometry(np.linspace(0.0, seg.length, n))
            chunks.append(np.column_stack((x, y)))
        return np.vstack(chunks)


# ------------------------------------------------------------------ shapes
def d_shape(line_centre, radius_m: float, *, clockwise: bool = True) -> Path:
    """The thesis's D: a straight line of length 2r centred at `line_centre`, parallel
    to y, closed by a half circle of radius r bulging towards +x.

    Clockwise (the default) goes up the line, then round the arc back down.
    """
    cx, cy = line_centre
    bottom, top = (cx, cy - radius_m), (cx, cy + radius_m)
    if clockwise:
        return Path((Line(bottom, top), Arc((cx, cy), radius_m, 0.5 * math.pi, -math.pi)))
    return Path((Arc((cx, cy), radius_m, -0.5 * math.pi, math.pi), Line(top, bottom)))


def circle(centre, radius_m: float, *, clockwise: bool = False) -> Path:
    """A full circle starting at its point nearest the subject (−y side is away)."""
    sweep = -2.0 * math.pi if clockwise else 2.0 * math.pi
    return Path((Arc(tuple(centre), radius_m, 0.5 * math.pi, sweep),))


def straight_reach(start, length_m: float, direction_rad: float = -0.5 * math.pi) -> Path:
    """Out along a straight line from `start` and back. The default direction, −y,
    is a forward reach away from a subject seated on the +y side."""
    end = (
        start[0] + length_m * math.cos(direction_rad),
        start[1] + length_m * math.sin(direction_rad),
    )
    return Path((Line(tuple(start), end), Line(end, tuple(start))))


NEGLECT_SIDES = ("", "left", "right")
"""The side of a hemispatial neglect a reaching layout is turned toward, the patient's: the
subject sits on +y facing −y, so the patient's left is +x (docs/frames.md)."""
AHEAD_RAD = -0.5 * math.pi
"""Straight ahead of the subject (−y), the direction of the first target."""
NEGLECT_REACH_TURN_RAD = 0.25 * math.pi
"""How far a straight reach turns toward the neglected side."""


def toward_side(side: str) -> float:
    """+1 toward the patient's left (+x), −1 toward the right (−x), 0 for no side."""
    if side not in NEGLECT_SIDES:
        raise ParameterError("neglect_side", side, "'', 'left' or 'right'")
    return {"": 0.0, "left": 1.0, "right": -1.0}[side]


def centre_out_angles(n_targets: int, toward: float = 0.0) -> list[float]:
    """The directions (rad, counter-clockwise from +x) of a centre-out layout's targets, in
    order: evenly round the circle from straight ahead; with `toward` ±1 (a neglect layout,
    Pedroli et al. 2015, doi 10.3389/fnbeh.2015.00226: reaching pushed into the neglected
    side) evenly over the half circle on that side, from straight ahead round to straight
    back."""
    if toward == 0.0:
        return [AHEAD_RAD + 2.0 * math.pi * k / n_targets for k in range(n_targets)]
    return [AHEAD_RAD + toward * math.pi * k / (n_targets - 1) for k in range(n_targets)]


def centre_out(home, radius_m: float, n_targets: int = 8, toward: float = 0.0) -> Path:
    """Point-to-point reaching: home → target k → home for n targets on a circle
    (the centre-out task of Kinarm and InMotion), first target straight ahead (−y);
    `toward` turns the layout to one side (centre_out_angles)."""
    home = tuple(home)
    segments: list[Segment] = []
    for angle in centre_out_angles(n_targets, toward):
        target = (home[0] + radius_m * math.cos(angle), home[1] + radius_m * math.sin(angle))
        segments += [Line(home, target), Line(target, home)]
    return Path(tuple(segments))


def figure_eight(crossing, radius_m: float) -> Path:
    """Two tangent circles of radius r meeting at `crossing`: the +x lobe
    counter-clockwise, then the −x lobe clockwise, so the tangent never jumps."""
    cx, cy = crossing
    return Path(
        (
            Arc((cx + radius_m, cy), radius_m, math.pi, 2.0 * math.pi),
            Arc((cx - radius_m, cy), radius_m, 0.0, -2.0 * math.pi),
        )
    )


def make_path(
    shape: str, centre, radius_m: float, *, clockwise: bool = True, n_targets: int = 8,
    toward: float = 0.0,
) -> Path:
    """The path of a trial's `shape` (one of SHAPES) from its centre and radius; `toward`
    (toward_side) turns a reaching layout to the patient's neglected side."""
    if shape == "d":
        return d_shape(centre, radius_m, clockwise=clockwise)
    if shape == "circle":
        return circle(centre, radius_m, clockwise=clockwise)
    if shape == "reach":
        return straight_reach(centre, 2.0 * radius_m, AHEAD_RAD + toward * NEGLECT_REACH_TURN_RAD)
    if shape == "targets":
        return centre_out(centre, radius_m, n_targets, toward)
    if shape == "figure8":
        return figure_eight(centre, radius_m)
    raise ParameterError("shape", shape, ", ".join(SHAPES))


# ------------------------------------------------------------------ timing
def minimum_jerk(u, span, length):
    """The minimum-jerk profile (Flash & Hogan 1985, J Neurosci 5:1688) of a move of
    `length` over `span` at u = t / span in [0, 1]: the distance covered, its rate and
    its acceleration (floats or arrays)."""
    u2 = u * u
    return (
        length * u2 * u * (10.0 - 15.0 * u + 6.0 * u2),
        length / span * 30.0 * u2 * (1.0 - 2.0 * u + u2),
        length / (span * span) * 60.0 * u * (1.0 - 3.0 * u + 2.0 * u2),
    )


@dataclass(frozen=True, slots=True)
class TrajectorySample:
    """Desired motion at an array of times: each field has shape (N, 2) or (N,)."""

    t_s: np.ndarray
    position_m: np.ndarray
    velocity_m_s: np.ndarray
    acceleration_m_s2: np.ndarray
    direction: np.ndarray  # unit tangent: the desired direction of motion
    segment: np.ndarray  # index of the segment being walked
    repetition: np.ndarray  # 0-based; equals `repetitions` after the end


@dataclass(frozen=True, slots=True)
class Trajectory:
    """A path walked `repetitions` times, `duration_s` per traversal."""

    path: Path
    duration_s: float
    repetitions: int = 1
    timing: str = "constant_speed"
    segment_times_s: tuple[float, ...] = field(init=False)

    def __post_init__(self) -> None:
        check_positive("duration_s", self.duration_s, "s")
        check_range("repetitions", self.repetitions, 1, 1000)
        if self.timing not in TIMINGS:
            raise ParameterError("timing", self.timing, ", ".join(TIMINGS))
        lengths = self.path.lengths
        times = np.concatenate(([0.0], np.cumsum(lengths))) / lengths.sum() * self.duration_s
        object.__setattr__(self, "segment_times_s", tuple(times.tolist()))

    @property
    def total_duration_s(self) -> float:
        return self.duration_s * self.repetitions

    @property
    def mean_speed_m_s(self) -> float:
        return self.path.length / self.duration_s

    @property
    def peak_speed_m_s(self) -> float:
        """Constant speed, or 15/8 of each segment's mean speed under minimum jerk.
        Every segment gets a time share proportional to its length, so all share
        the same mean speed."""
        factor = 1.875 if self.timing == "minimum_jerk" else 1.0
        return factor * self.mean_speed_m_s

    def sample(self, t_s) -> TrajectorySample:
        """Desired motion at the times `t_s` (any shape, flattened)."""
        t = np.asarray(t_s, dtype=float).ravel()
        seg_t = np.asarray(self.segment_times_s)
        rep = np.floor(t / self.duration_s).astype(int)
        tau = t - rep * self.duration_s
        finished = rep >= self.repetitions
        resting = finished | (t < 0.0)
        tau = np.where(resting, 0.0, np.clip(tau, 0.0, self.duration_s))
        rep = np.clip(rep, 0, self.repetitions)
        idx = np.clip(np.searchsorted(seg_t, tau, side="right") - 1, 0, len(self.path.segments) - 1)
        out = np.zeros((t.size, 6))
        s = np.zeros(t.size)
        sd = np.zeros(t.size)
        sdd = np.zeros(t.size)
        for k, seg in enumerate(self.path.segments):
            sel = idx == k
            if not sel.any():
                continue
            sk, sdk, sddk = self._timing(tau[sel] - seg_t[k], seg_t[k + 1] - seg_t[k], seg.length)
            s[sel], sd[sel], sdd[sel] = sk, sdk, sddk
            out[sel] = np.column_stack(seg.geometry(sk))
        sd = np.where(resting, 0.0, sd)
        sdd = np.where(resting, 0.0, sdd)
        tangent = out[:, 2:4]
        curvature = out[:, 4:6]
        return TrajectorySample(
            t,
            out[:, 0:2],
            tangent * sd[:, None],
            tangent * sdd[:, None] + curvature * (sd * sd)[:, None],
            tangent,
            idx,
            rep,
        )

    def _timing(self, tau, span, length):
        """Arc length, speed and its rate within one segment at local time tau."""
        if self.timing == "constant_speed":
            speed = length / span
            return speed * tau, speed + 0.0 * tau, 0.0 * tau
        return minimum_jerk(tau / span, span, length)

    def at(self, t: float):
        """Desired (x, y, vx, vy, ax, ay, direction_x, direction_y) at one time, floats."""
        seg_t = self.segment_times_s
        rep = math.floor(t / self.duration_s)
        resting = rep >= self.repetitions or t < 0.0
        tau = 0.0 if resting else min(max(t - rep * self.duration_s, 0.0), self.duration_s)
        k = min(max(bisect.bisect_right(seg_t, tau) - 1, 0), len(self.path.segments) - 1)
        seg = self.path.segments[k]
        s, sd, sdd = self._timing(tau - seg_t[k], seg_t[k + 1] - seg_t[k], seg.length)
        if resting:
            sd = sdd = 0.0
        x, y, tx, ty, kx, ky = seg.geometry(s)
        return (x, y, tx * sd, ty * sd, tx * sdd + kx * sd * sd, ty * sdd + ky * sd * sd, tx, ty)

    def joint_reference(self, robot: RobotModel, t_s):
        """Desired joint angles, rates and accelerations of the robot at `t_s`.

        θ_d = IK(P_d), θ̇_d = J_R⁻¹ Ṗ_d, θ̈_d = J_R⁻¹ (P̈_d − J̇_R θ̇_d)   (eq. 3.1, 3.4, 3.5)
        Returns (q, qd, qdd), each shape (N, 2). Raises UnreachableError.
        """
        sample = self.sample(t_s)
        return joint_motion(robot, sample.position_m, sample.velocity_m_s,
                            sample.acceleration_m_s2)
