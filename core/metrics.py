"""A trial's performance figures: the thesis's report (section 3.6) and what a
Kinarm or InMotion user expects beside it.

Thesis figures (section 3.6, Fig. 3.7, 3.9, 3.11, 3.12): RMSE of the position in
x and y, directional performance (the share of the trial during which the hand's
force points within a tolerance of the desired direction, with the blue/red
intervals of Fig. 3.9), force ranges in x and y, ISB shoulder and elbow range of
motion (eq. 3.37–3.38) and the joint torque ranges, raw and smoothed with the
Butterworth filter the thesis suggests (section 3.6.3).

Beyond the thesis: path length ratio, mean and peak speed, movement time,
SPARC and LDLJ (core.smoothness), per-reach reaction time, initial direction
error, movement time and smoothness (core.reaches), and the shoulder–elbow
correlation.

Everything is computed from plain arrays sampled evenly in time (see
`compute_metrics`), in SI units; degrees belong to the display.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, fields

import numpy as np

from core.errors import check_non_negative, check_range
from core.reaches import (
    DEFAULT_INITIAL_WINDOW_S,
    DEFAULT_MIN_PEAK_SPEED_M_S,
    DEFAULT_ONSET_FRACTION,
    Reach,
    ReachMetrics,
    mean_finite,
    reach_metrics,
)
from core.signal import as_series, lowpass, sample_interval, smoothed_derivatives
from core.smoothness import ldlj, sparc
from core.work import MechanicalWork, helped_samples, mechanical_work

DEFAULT_TOLERANCE_RAD = math.radians(20.0)  # the thesis's choice, section 3.6.1
# The force sensor resolves 1/24 N per axis. Half a count on each axis moves the
# force vector by up to 0.03 N, which at 0.25 N turns it by at most 7° — a third
# of the default tolerance. Below that the direction is quantisation, not intent.
DEFAULT_MIN_FORCE_N = 0.25
# Human voluntary movement and the torques it needs lie below 10 Hz, the band
# SPARC also stops at (Balasubramanian et al. 2015).
DEFAULT_SPEED_CUTOFF_HZ = 10.0
DEFAULT_TORQUE_CUTOFF_HZ = 10.0
DEFAULT_FILTER_ORDER = 4

Interval = tuple[float, float]


@dataclass(frozen=True, slots=True, eq=False)
class DirectionalPerformance:
    """Directional performance of section 3.6.1 and the colouring of Fig. 3.9.

    within: per sample, whether the force was within the tolerance (bool, (N,)).
    percent: share of the trial time within, in % (0–100).
    within_intervals_s, outside_intervals_s: (start, end) times in s of the runs
    within (blue in Fig. 3.9) and outside (red); together they tile
    [t_s[0], t_s[-1]].
    """

    within: np.ndarray
    percent: float
    within_intervals_s: tuple[Interval, ...]
    outside_intervals_s: tuple[Interval, ...]


@dataclass(frozen=True, slots=True)
class TrialMetrics:
    """A trial's figures, SI units. NaN where a figure does not apply (its
    channel was not given, no movement, no reaches).

    duration_s: t_s[-1] − t_s[0] (s).
    rmse_x_m, rmse_y_m: √(mean over samples of (p − p_d)²) per axis (m), as in
        Fig. 3.7 (8.68 mm and 7.02 mm in the thesis).
    directional_performance_pct: % of the trial time the force was within
        `tolerance_rad` of the desired direction (78 % in the thesis). Sample k
        holds over [t_k, t_{k+1}); a force weaker than `min_force_N`, or a
        desired direction of zero length, counts as outside.
    tolerance_rad, min_force_N: the settings the percentage was computed with.
    force_range_x_N, force_range_y_N: max − min of the hand's force per axis (N)
        (0.835 N and 2.528 N in Fig. 3.9).
    shoulder_rom_rad, elbow_rom_rad: max − min of the ISB angles (rad), eq.
        3.37–3.38 (42.17° and 30.65° in Fig. 3.11).
    shoulder_torque_range_Nm, elbow_torque_range_Nm: max − min of the raw joint
        torques (N·m) (4.79 and 0.817 N·m in Fig. 3.12).
    shoulder_torque_range_smoothed_Nm, elbow_torque_range_smoothed_Nm: the same
        after the zero-lag Butterworth low-pass (core.signal.lowpass).
    path_length_m: ∫|v| dt over the trial of the smoothed hand speed (m).
    desired_path_length_m: sum of the distances between successive desired
        positions (m).
    path_length_ratio: path_length_m / desired_path_length_m (1 is ideal).
    peak_speed_m_s: highest smoothed hand speed (m/s).
    movement_onset_s, movement_offset_s: first and last times the speed crosses
        `movement_fraction` of its peak (interpolated; t_s[0] or t_s[-1] when
        already above there) (s).
    movement_time_s: offset − onset (s).
    mean_speed_m_s: time-average of the speed from the first to the last sample
        at or above the threshold (m/s).
    sparc: SPARC of the whole trial's speed profile (core.smoothness.sparc).
    ldlj: LDLJ of the velocity vector from the first to the last sample at or
        above the threshold (core.smoothness.ldlj).
    n_reaches: number of reaches given.
    reaction_time_s, reach_movement_time_s, initial_direction_error_rad,
        reach_sparc, reach_ldlj: means over the reaches where they are defined
        (core.reaches); the initial direction error is the mean of the
        absolute angles (rad), the signed ones are in `reaches`.
    robot_work_J, patient_work_J, robot_negative_work_J, robot_help_work_J,
        robot_work_share: who did the work (`core.work.mechanical_work`), NaN without the robot's
        torques and angles (the help and the share also without its own torque).
    led_pct: % of the trial time the patient led, the as-needed robot adding no help
        along the path (core.control.guidance: the patient within the delay of the
        clock, or ahead of it); NaN in the thesis mode, which has no such help.
    shoulder_elbow_correlation: Pearson correlation of the ISB shoulder and
        elbow angle series (−1…1); NaN when either does not vary.
    within_intervals_s, outside_intervals_s: Fig. 3.9's blue and red runs (s);
        empty unless both force_N and desired_direction were given.
    reaches: per-reach measures (core.reaches.ReachMetrics).
    """

    duration_s: float
    rmse_x_m: float
    rmse_y_m: float
    directional_performance_pct: float
    tolerance_rad: float
    min_force_N: float
    force_range_x_N: float
    force_range_y_N: float
    shoulder_rom_rad: float
    elbow_rom_rad: float
    shoulder_torque_range_Nm: float
    elbow_torque_range_Nm: float
    shoulder_torque_range_smoothed_Nm: float
    elbow_torque_range_smoothed_Nm: float
    path_length_m: float
    desired_path_length_m: float
    path_length_ratio: float
    peak_speed_m_s: float
    movement_onset_s: float
    movement_offset_s: float
    movement_time_s: float
    mean_speed_m_s: float
    sparc: float
    ldlj: float
    n_reaches: int
    reaction_time_s: float
    reach_movement_time_s: float
    initial_direction_error_rad: float
    reach_sparc: float
    reach_ldlj: float
    shoulder_elbow_correlation: float
    within_intervals_s: tuple[Interval, ...] = ()
    outside_intervals_s: tuple[Interval, ...] = ()
    reaches: tuple[ReachMetrics, ...] = ()
    robot_work_J: float = math.nan
    patient_work_J: float = math.nan
    robot_negative_work_J: float = math.nan
    robot_work_share: float = math.nan
    led_pct: float = math.nan
    robot_help_work_J: float = math.nan

    def to_dict(self) -> dict[str, float]:
        """Every scalar figure as a plain float, keyed by field name (SI units,
        as named). The interval and per-reach tuples are left out: read them from
        the attributes."""
        return {
            f.name: float(getattr(self, f.name))
            for f in fields(self)
            if not isinstance(getattr(self, f.name), tuple)
        }


# ------------------------------------------------------------------ formulas
def rmse_xy(position_m, desired_position_m) -> tuple[float, float]:
    """Root-mean-square error per axis (m): √(mean_k (p_k − p_d,k)²), Fig. 3.7."""
    error = np.asarray(position_m, dtype=float) - np.asarray(desired_position_m, dtype=float)
    rms = np.sqrt(np.mean(error * error, axis=0))
    return (float(rms[0]), float(rms[1]))


def value_range(values) -> np.ndarray:
    """max − min along axis 0 (the thesis's force, ROM and torque 'ranges')."""
    array = np.asarray(values, dtype=float)
    return array.max(axis=0) - array.min(axis=0)


def directional_performance(
    t_s,
    force_N,
    desired_direction,
    tolerance_rad: float = DEFAULT_TOLERANCE_RAD,
    min_force_N: float = DEFAULT_MIN_FORCE_N,
) -> DirectionalPerformance:
    """Share of the trial time the hand's force points within `tolerance_rad` of
    the desired direction (section 3.6.1, Fig. 3.9).

    At each sample the angle between F and the desired direction d is
    atan2(|F × d|, F·d) ∈ [0, π]; the sample is within when that angle is at most
    `tolerance_rad` and |F| ≥ `min_force_N`. A weaker force counts as outside
    (no direction can be read from it, and a subject who does not push is not
    performing), as does a desired direction of zero length. `desired_direction`
    need not be unit length (a desired velocity works too).

    Time weighting: sample k holds over [t_k, t_{k+1}), so the last sample has no
    duration and the intervals tile [t_0, t_{N−1}] exactly; the percentage is
    the within time over t_{N−1} − t_0.
    """
    tolerance_rad = check_range("tolerance_rad", tolerance_rad, 0.0, math.pi, "rad",
                                low_open=True)
    min_force_N = check_non_negative("min_force_N", min_force_N, "N")
    t = np.asarray(t_s, dtype=float)
    sample_interval(t)
    force = as_series("force_N", force_N, t.size, 2)
    direction = as_series("desired_direction", desired_direction, t.size, 2)
    within = force_within(force, direction, tolerance_rad, min_force_N)

    held = within[:-1]
    change = np.flatnonzero(held[1:] != held[:-1]) + 1
    starts = np.concatenate(([0], change))
    ends = np.concatenate((change, [t.size - 1]))
    inside: list[Interval] = []
    outside: list[Interval] = []
    within_time = 0.0
    for a, b in zip(starts, ends, strict=True):
        interval = (float(t[a]), float(t[b]))
        if held[a]:
            inside.append(interval)
            within_time += interval[1] - interval[0]
        else:
            outside.append(interval)
    percent = 100.0 * within_time / float(t[-1] - t[0])
    return DirectionalPerformance(within, percent, tuple(inside), tuple(outside))


def force_within(force: np.ndarray, direction: np.ndarray, tolerance_rad: float,
                 min_force_N: float) -> np.ndarray:
    """Per sample, whether the force (N, 2) points within `tolerance_rad` of the desired
    direction (N, 2) and is at least `min_force_N` (`directional_performance`)."""
    cross = force[:, 0] * direction[:, 1] - force[:, 1] * direction[:, 0]
    dot = np.sum(force * direction, axis=1)
    angle = np.arctan2(np.abs(cross), dot)
    strong = np.hypot(force[:, 0], force[:, 1]) >= min_force_N
    defined = np.hypot(direction[:, 0], direction[:, 1]) > 0.0
    return strong & defined & (angle <= tolerance_rad)


def pearson(a, b) -> float:
    """Pearson correlation coefficient of two series; NaN when either is constant."""
    x = np.asarray(a, dtype=float) - np.mean(a)
    y = np.asarray(b, dtype=float) - np.mean(b)
    denominator = math.sqrt(float(x @ x) * float(y @ y))
    if denominator == 0.0:
        return math.nan
    return float(np.clip((x @ y) / denominator, -1.0, 1.0))


def movement_interval(t_s, speed_m_s, fraction: float) -> tuple[float, float, int, int]:
    """First and last times the speed crosses `fraction` of its peak, interpolated
    between samples (t_s[0] / t_s[-1] when the speed is above it there), and the
    first and last sample indices at or above it."""
    t = np.asarray(t_s, dtype=float)
    speed = np.asarray(speed_m_s, dtype=float)
    threshold = fraction * speed.max()
    above = np.flatnonzero(speed >= threshold)
    first, last = int(above[0]), int(above[-1])
    onset = float(t[0]) if first == 0 else _cross(t, speed, first - 1, first, threshold)
    offset = float(t[-1]) if last == t.size - 1 else _cross(t, speed, last, last + 1, threshold)
    return onset, offset, first, last


def _cross(t, speed, i, j, threshold) -> float:
    share = (threshold - speed[i]) / (speed[j] - speed[i])
    return float(t[i] + share * (t[j] - t[i]))


# ------------------------------------------------------------------ the trial
def compute_metrics(
    t_s,
    position_m,
    *,
    desired_position_m=None,
    desired_direction=None,
    force_N=None,
    isb_angles_rad=None,
    torque_Nm=None,
    robot_torque_Nm=None,
    robot_angle_rad=None,
    robot_own_torque_Nm=None,
    help_torque_Nm=None,
    tolerance_rad: float = DEFAULT_TOLERANCE_RAD,
    min_force_N: float = DEFAULT_MIN_FORCE_N,
    reaches: Sequence[Reach] | None = None,
    speed_cutoff_hz: float | None = DEFAULT_SPEED_CUTOFF_HZ,
    torque_cutoff_hz: float | None = DEFAULT_TORQUE_CUTOFF_HZ,
    filter_order: int = DEFAULT_FILTER_ORDER,
    movement_fraction: float = DEFAULT_ONSET_FRACTION,
    min_peak_speed_m_s: float = DEFAULT_MIN_PEAK_SPEED_M_S,
    initial_window_s: float = DEFAULT_INITIAL_WINDOW_S,
) -> TrialMetrics:
    """All of a trial's figures from its recorded arrays.

    t_s (N,) s, evenly sampled (core.signal.sample_interval); position_m (N, 2)
    hand/end-effector position; desired_position_m (N, 2); desired_direction
    (N, 2) unit path tangent; force_N (N, 2) the hand's force on the handle in
    the global frame; isb_angles_rad (N, 2) ISB shoulder, elbow; torque_Nm
    (N, 2) subject's shoulder, elbow torques; robot_torque_Nm (N, 2) the torques the
    drives applied and robot_angle_rad (N, 2) the joints' angles (with force_N, for
    `core.work.mechanical_work`), robot_own_torque_Nm (N, 2) their part that carried the robot's
    own dynamics (core.control.own; for the help and its share); help_torque_Nm (N, 2)
    the as-needed robot's help along the path at the joints (for `led_pct`). Every
    array must be finite; the figures of a channel left as None are NaN.

    Hand speed is the norm of the derivative of the position after the zero-lag
    Butterworth low-pass at `speed_cutoff_hz` (None: no filtering, for clean
    signals), because encoder quantisation makes raw differences useless for
    jerk and spectra. `torque_cutoff_hz` (None: skip) sets the filter of the
    smoothed torque ranges. `reaches` (e.g. core.reaches.reaches_from_trajectory)
    enables the per-reach figures. See TrialMetrics for every definition.
    """
    dt_s = sample_interval(t_s)
    t = np.asarray(t_s, dtype=float)
    n = t.size
    position = as_series("position_m", position_m, n, 2)
    tolerance_rad, min_force_N = checked_options(tolerance_rad, min_force_N, movement_fraction)
    nan = math.nan
    pair = (nan, nan)

    rmse = pair
    desired_length = nan
    if desired_position_m is not None:
        desired = as_series("desired_position_m", desired_position_m, n, 2)
        rmse = rmse_xy(position, desired)
        desired_length = float(np.sum(np.hypot(*np.diff(desired, axis=0).T)))

    direction_pct, within, outside = nan, (), ()
    force_range = pair
    if desired_direction is not None:
        desired_direction = as_series("desired_direction", desired_direction, n, 2)
    if force_N is not None:
        force = as_series("force_N", force_N, n, 2)
        force_range = tuple(float(v) for v in value_range(force))
        if desired_direction is not None:
            result = directional_performance(t, force, desired_direction, tolerance_rad,
                                             min_force_N)
            direction_pct = result.percent
            within, outside = result.within_intervals_s, result.outside_intervals_s

    rom, correlation = pair, nan
    if isb_angles_rad is not None:
        isb = as_series("isb_angles_rad", isb_angles_rad, n, 2)
        rom = tuple(float(v) for v in value_range(isb))
        correlation = pearson(isb[:, 0], isb[:, 1])

    torque_range, smoothed_range = pair, pair
    if torque_Nm is not None:
        torque = as_series("torque_Nm", torque_Nm, n, 2)
        torque_range = tuple(float(v) for v in value_range(torque))
        if torque_cutoff_hz is not None:
            smooth = lowpass(torque, dt_s, torque_cutoff_hz, filter_order, name="torque_Nm")
            smoothed_range = tuple(float(v) for v in value_range(smooth))

    velocity = smoothed_derivatives(position, dt_s, speed_cutoff_hz, filter_order,
                                    name="position_m").rate
    speed = np.hypot(velocity[:, 0], velocity[:, 1])
    path_length = float(np.trapezoid(speed, t))
    peak = float(speed.max())
    onset = offset = mean_speed = trial_sparc = trial_ldlj = nan
    if peak >= min_peak_speed_m_s:
        onset, offset, first, last = movement_interval(t, speed, movement_fraction)
        if last > first:
            span = slice(first, last + 1)
            mean_speed = float(np.trapezoid(speed[span], t[span]) / (t[last] - t[first]))
        trial_sparc = sparc(speed, dt_s)
        trial_ldlj = ldlj(velocity[first:last + 1], dt_s) if last - first >= 3 else nan

    work = MechanicalWork(nan, nan, nan, nan)
    if robot_torque_Nm is not None and robot_angle_rad is not None and force_N is not None:
        own = (None if robot_own_torque_Nm is None
               else as_series("robot_own_torque_Nm", robot_own_torque_Nm, n, 2))
        work = mechanical_work(as_series("robot_torque_Nm", robot_torque_Nm, n, 2),
                               as_series("robot_angle_rad", robot_angle_rad, n, 2),
                               force, position, own)

    led = nan
    if help_torque_Nm is not None:
        led = 100.0 * (1.0 - float(np.mean(
            helped_samples(as_series("help_torque_Nm", help_torque_Nm, n, 2)))))

    per_reach: tuple[ReachMetrics, ...] = ()
    if reaches:
        per_reach = reach_metrics(
            t, position, velocity, reaches, onset_fraction=movement_fraction,
            min_peak_speed_m_s=min_peak_speed_m_s, initial_window_s=initial_window_s,
        )

    return assemble(float(t[-1] - t[0]), rmse, direction_pct, tolerance_rad, min_force_N,
                    force_range, rom, torque_range, smoothed_range, path_length,
                    desired_length, peak, onset, offset, mean_speed, trial_sparc, trial_ldlj,
                    correlation, within, outside, per_reach, work, led)


def checked_options(tolerance_rad: float, min_force_N: float,
                    movement_fraction: float) -> tuple[float, float]:
    """The options `compute_metrics` and core.blockwise check before any figure (the cone's
    half-angle, the force a direction needs, the onset's share of the peak speed)."""
    tolerance_rad = check_range("tolerance_rad", tolerance_rad, 0.0, math.pi, "rad",
                                low_open=True)
    min_force_N = check_non_negative("min_force_N", min_force_N, "N")
    check_range("movement_fraction", movement_fraction, 0.0, 1.0, low_open=True)
    return tolerance_rad, min_force_N


def assemble(duration_s, rmse, direction_pct, tolerance_rad, min_force_N, force_range, rom,
             torque_range, smoothed_range, path_length, desired_length, peak, onset, offset,
             mean_speed, trial_sparc, trial_ldlj, correlation, within, outside, per_reach,
             work, led) -> TrialMetrics:
    """TrialMetrics from its figures as `compute_metrics` (or core.blockwise) found them:
    the ratios and the means over the reaches derived here."""
    nan = math.nan
    return TrialMetrics(
        duration_s=duration_s,
        rmse_x_m=rmse[0],
        rmse_y_m=rmse[1],
        directional_performance_pct=direction_pct,
        tolerance_rad=tolerance_rad,
        min_force_N=min_force_N,
        force_range_x_N=force_range[0],
        force_range_y_N=force_range[1],
        shoulder_rom_rad=rom[0],
        elbow_rom_rad=rom[1],
        shoulder_torque_range_Nm=torque_range[0],
        elbow_torque_range_Nm=torque_range[1],
        shoulder_torque_range_smoothed_Nm=smoothed_range[0],
        elbow_torque_range_smoothed_Nm=smoothed_range[1],
        path_length_m=path_length,
        desired_path_length_m=desired_length,
        path_length_ratio=path_length / desired_length if desired_length > 0.0 else nan,
        peak_speed_m_s=peak,
        movement_onset_s=onset,
        movement_offset_s=offset,
        movement_time_s=offset - onset,
        mean_speed_m_s=mean_speed,
        sparc=trial_sparc,
        ldlj=trial_ldlj,
        n_reaches=len(per_reach),
        reaction_time_s=mean_finite(r.reaction_time_s for r in per_reach),
        reach_movement_time_s=mean_finite(r.movement_time_s for r in per_reach),
        initial_direction_error_rad=mean_finite(
            abs(r.initial_direction_error_rad) for r in per_reach),
        reach_sparc=mean_finite(r.sparc for r in per_reach),
        reach_ldlj=mean_finite(r.ldlj for r in per_reach),
        shoulder_elbow_correlation=correlation,
        within_intervals_s=within,
        outside_intervals_s=outside,
        reaches=per_reach,
        robot_work_J=work.robot_J,
        patient_work_J=work.patient_J,
        robot_negative_work_J=work.robot_negative_J,
        robot_work_share=work.robot_share,
        led_pct=led,
        robot_help_work_J=work.help_J,
    )
