"""The report's plots, each drawn onto a `Sheet` (app.reports.pdf_sheet) below its current
height: the hand's path against the target (Fig. 3.7) on page 1; the force on the
handle (Fig. 3.9), the ISB joint angles (Fig. 3.11) and the joint torques
(Fig. 3.12) on page 2.

Every colour has a line style too: within the tolerance solid blue, outside it
dashed vermillion; shoulder solid purple, elbow dash-dotted green. Long time
series are thinned to their per-bucket minima and maxima (`MAX_LINE_POINTS` a
line), so a 20-minute trial draws as fast as a short one and keeps the peaks its
ranges are made of.
"""

from __future__ import annotations

import math

import matplotlib.lines
import numpy as np
from matplotlib.axes import Axes

from app.reports.figures import (
    AnglesFigure,
    EmgFigure,
    FeedforwardFigure,
    ForceFigure,
    PathFigure,
    PoseFigure,
    Run,
    TorquesFigure,
)
from app.reports.pdf_sheet import (
    BLUE,
    GREEN,
    GREY,
    INK,
    LEFT_IN,
    PLOT_RIGHT_IN,
    PURPLE,
    TARGET_GREY,
    TEXT_W_IN,
    VERMILLION,
    Sheet,
)
from app.units import CM_PER_M

MAX_LINE_POINTS = 2500
# Page 1 around the path's axes: gap, heading and legend above; tick labels, axis
# label and the two caption lines below.
PATH_ABOVE_IN = 0.62
PATH_BELOW_IN = 0.8
TIME_LABEL = "time since the exercise started (s)"

_JOINT_STYLES = ((PURPLE, "-"), (GREEN, "-."))


# -- page 1 ------------------------------------------------------------------------------

def path_plot(sheet: Sheet, figure: PathFigure | None) -> None:
    """Fig. 3.7 in the rest of the page, as the patient sees it from their seat: the
    patient sits on +y facing −y (docs/frames.md), so both axes reversed (the robot's
    side at the top, the patient's right on the right). No coordinates: a scale bar
    gives the size."""
    if figure is None:
        sheet.text("No path to show: the trial has no exercise samples of the hand's "
                   "position.", 11, color=GREY)
        return
    sheet.text("Your hand's path and the path to follow", 12, weight="bold")
    handles = [
        matplotlib.lines.Line2D([], [], color=TARGET_GREY, linewidth=7, label="path to follow"),
        matplotlib.lines.Line2D([], [], color=INK, marker="o", markersize=6, linestyle="none",
                                label="start"),
        *(run_handles(figure.runs, *figure.run_labels) if figure.runs else
          # one line, nothing to judge it by (_draw_runs): still named
          [matplotlib.lines.Line2D([], [], color=INK, linewidth=1.6, label="your hand")]),
    ]
    sheet.legend(handles, LEFT_IN, ncols=4)
    sheet.y_in += 0.2  # the robot's side is written above the drawing
    height = max(1.0, sheet.room_in - PATH_BELOW_IN)
    ax = sheet.axes(height, x_in=LEFT_IN, width_in=TEXT_W_IN)
    desired = figure.desired_m * CM_PER_M
    position = figure.position_m * CM_PER_M
    outline = figure.outline_m * CM_PER_M
    ax.plot(outline[:, 0], outline[:, 1], color=TARGET_GREY, linewidth=7,
            solid_capstyle="round", zorder=1)
    _draw_runs(ax, position[:, 0], position[:, 1], figure.runs, linewidth=1.6)
    ax.plot(*desired[0], marker="o", markersize=6, color=INK, linestyle="none", zorder=4)
    _direction_arrow(ax, outline)
    # The box shrinks to the data's shape, so centimetres are equal both ways.
    ax.set_aspect("equal", adjustable="box")
    ax.set_anchor("C")
    ax.margins(0.12)
    ax.invert_xaxis()
    ax.invert_yaxis()
    ax.set_xticks([])
    ax.set_yticks([])
    for spine in ax.spines.values():
        spine.set_visible(False)
    _scale_bar(ax, np.vstack((outline, position)))
    ax.text(0.5, 1.0, "the robot's side", transform=ax.transAxes, ha="center", va="bottom",
            fontsize=8.5, color=GREY)
    ax.text(0.5, 0.0, "you sit here", transform=ax.transAxes, ha="center", va="top",
            fontsize=8.5, color=GREY)
    sheet.y_in += height + 0.3
    sheet.text("Seen from your seat, as you sat at the table.", 9.5, color=GREY,
               scaled=False)


def _scale_bar(ax: Axes, points_cm: np.ndarray) -> None:
    """A bar of a round length (1, 2, 5, 10 or 20 cm, about a fifth of the drawing's
    width) in the bottom left corner as the patient sees it, with its length."""
    span = float(np.ptp(points_cm[:, 0]))
    length = next((c for c in (20.0, 10.0, 5.0, 2.0, 1.0) if c <= 0.3 * span), 1.0)
    # reversed axes: the patient's bottom left is the largest x and y
    x0 = float(points_cm[:, 0].max())
    y0 = float(points_cm[:, 1].max()) + 0.06 * max(span, float(np.ptp(points_cm[:, 1])))
    ax.plot([x0, x0 - length], [y0, y0], color=INK, linewidth=2.0, solid_capstyle="butt",
            zorder=5)
    ax.annotate(f"{length:g} cm", (x0 - length / 2.0, y0), xytext=(0, -3),
                textcoords="offset points", ha="center", va="top", fontsize=8, color=INK)


def _direction_arrow(ax: Axes, desired_cm: np.ndarray) -> None:
    """An arrow along the first few percent of the target path: the way to go."""
    steps = np.hypot(*np.diff(desired_cm, axis=0).T)
    along = np.concatenate(([0.0], np.cumsum(steps)))
    if along[-1] <= 0:
        return
    k = int(np.searchsorted(along, 0.06 * along[-1]))
    k = min(max(k, 1), len(desired_cm) - 1)
    ax.annotate("", xy=desired_cm[k], xytext=desired_cm[0],
                arrowprops={"arrowstyle": "-|>", "color": INK, "linewidth": 1.2,
                            "shrinkA": 4, "shrinkB": 0}, zorder=5)


# -- page 2 ------------------------------------------------------------------------------

def force_plots(sheet: Sheet, force: ForceFigure, x0: float, plot_w: float) -> None:
    """Fig. 3.9: heading, caption, legend, and Fx over Fy sharing their time axis."""
    sheet.text("Force on the handle (Fig. 3.9)", 10, weight="bold", advance=False)
    sheet.text(force.caption, 8.5, color=GREY, x_in=LEFT_IN + 2.35,
               width_in=TEXT_W_IN - 2.35)
    sheet.gap(0.04)
    handles = run_handles(force.runs, force.within_label, force.outside_label)
    if handles:
        sheet.legend(handles, LEFT_IN, ncols=2)
    sheet.gap(0.2)
    height = 0.75
    top = None
    for axis in range(2):
        ax = sheet.axes(height, x_in=x0, width_in=plot_w)
        ax.set_title(force.titles[axis], loc="left", pad=3)
        ax.axhline(0.0, color=TARGET_GREY, linewidth=0.6, zorder=0)
        _draw_runs(ax, force.t_s, force.force_N[:, axis], force.runs, linewidth=1.2)
        ax.set_ylabel("N")
        ax.set_xlim(force.t_s[0], force.t_s[-1])
        _light_grid(ax)
        if top is None:
            top = ax
            ax.tick_params(labelbottom=False)
            sheet.y_in += height + 0.27
        else:
            ax.sharex(top)
            ax.set_xlabel(TIME_LABEL)
            sheet.y_in += height + 0.45


def joint_plots(sheet: Sheet, angles: AnglesFigure | None, torques: TorquesFigure | None,
                x0: float, label_room: float) -> None:
    """Fig. 3.11 and 3.12 side by side (either may be missing), then below both."""
    between = 0.35
    half = (PLOT_RIGHT_IN - LEFT_IN - 2 * label_room - between) / 2
    x1 = x0 + half + between + label_room
    top_in = sheet.y_in
    height = 0.95
    bottom_in = top_in
    for figure, x, title in (
        (angles, x0, "Joint angles, ISB (Fig. 3.11)"),
        (torques, x1, "Joint torques (Fig. 3.12)"),
    ):
        if figure is None:
            continue
        sheet.y_in = top_in
        sheet.text(title, 10, weight="bold", x_in=x - label_room)
        sheet.gap(0.03)
        sheet.legend(_joint_handles(figure), x - label_room, ncols=1, size=7.5)
        sheet.gap(0.04)
        ax = sheet.axes(height, x_in=x, width_in=half)
        _plot_series(ax, figure)
        ax.set_xlabel(TIME_LABEL)
        sheet.y_in += height + 0.42
        if figure is torques:
            sheet.text(figure.caption, 7.5, color=GREY, x_in=x - label_room,
                       width_in=half + label_room)
        bottom_in = max(bottom_in, sheet.y_in)
    sheet.y_in = bottom_in + 0.1


_MUSCLE_STYLES = ((BLUE, "-"), (VERMILLION, "--"), (GREEN, "-."), (PURPLE, ":"))


def emg_plots(sheet: Sheet, emg: EmgFigure, torques: TorquesFigure | None, x0: float,
              width: float) -> None:
    """Each muscle's envelope in % MVC above the joint torques, on one time axis, then a line
    per muscle on its MVC."""
    height = 2.2
    handles = [matplotlib.lines.Line2D([], [], color=c, linestyle=ls, linewidth=1.4,
                                       label=name)
               for (c, ls), name in zip(_MUSCLE_STYLES, emg.names, strict=False)]
    sheet.text("Envelopes in % of the session's MVC (RMS, 0.125 s window)", 10, weight="bold")
    sheet.gap(0.03)
    sheet.legend(handles, x0 - 0.55, ncols=len(handles), size=7.5)
    sheet.gap(0.04)
    ax = sheet.axes(height, x_in=x0, width_in=width)
    for i, (colour, style) in enumerate(_MUSCLE_STYLES[:len(emg.muscles)]):
        x, y = _envelope(emg.t_s, emg.percent[:, i])
        ax.plot(x, y, color=colour, linestyle=style, linewidth=1.2)
    ax.set_ylabel("% MVC")
    ax.set_xlim(emg.t_s[0], emg.t_s[-1])
    _light_grid(ax)
    sheet.y_in += height + 0.42
    if torques is not None:
        sheet.text("Joint torques on the same time axis (Fig. 3.12)", 10, weight="bold")
        sheet.gap(0.03)
        sheet.legend(_joint_handles(torques), x0 - 0.55, ncols=2, size=7.5)
        sheet.gap(0.04)
        ax = sheet.axes(height, x_in=x0, width_in=width)
        _plot_series(ax, torques)
        ax.set_xlim(emg.t_s[0], emg.t_s[-1])
        ax.set_xlabel(TIME_LABEL)
        sheet.y_in += height + 0.5
    for line in emg.quality:
        sheet.text(line, 9, color=INK if line.endswith("sound") else VERMILLION)


LEARNED_NONE_N = 0.05
"""Learned help below this everywhere is none: the page's figures, to 0.1 N, say 0.0 N."""


def feedforward_plot(sheet: Sheet, figure: FeedforwardFigure, x0: float,
                     width: float) -> None:
    """The help the robot learned along the path, one line per finished repetition, the
    first light and the last dark, so a therapist sees it grow where the patient needed
    pulling and fade where they did the work (core.control.guidance)."""
    height = 2.6
    reps = figure.force_N.shape[0]
    sheet.text("The help the robot learned along the path, at the end of each repetition",
               10, weight="bold")
    sheet.gap(0.03)
    if float(np.max(figure.force_N)) < LEARNED_NONE_N:
        # every line on the chart's floor, hidden by its axis: an empty chart said nothing
        sheet.text(f"None: under {LEARNED_NONE_N:g} N at every point of all {reps} "
                   f"repetitions (limit {figure.limit_N:g} N; the assistance level ran at "
                   f"{figure.levels}). The hand never fell far enough behind the path for "
                   "the robot to learn a push along it.", 9)
        sheet.y_in += 0.3
        return
    first, last = figure.force_N[0], figure.force_N[-1]
    # one repetition: said once ("repetition 1: …; repetition 1: …" read as a slip)
    learned = (f"Repetition 1: up to {np.max(first):.1f} N; repetition {reps}: up to "
               f"{np.max(last):.1f} N" if reps > 1
               else f"One repetition: up to {np.max(first):.1f} N")
    sheet.text(f"{learned} (limit {figure.limit_N:g} N; the assistance level ran at "
               f"{figure.levels}).", 9)
    sheet.gap(0.06)
    ax = sheet.axes(height, x_in=x0, width_in=width)
    for k, row in enumerate(figure.force_N):
        shade = 0.25 + 0.75 * (k + 1) / reps  # later repetitions darker
        ax.plot(figure.percent_of_repetition, row, color=BLUE, alpha=shade, linewidth=1.3,
                label=f"repetition {k + 1}" if k in (0, reps - 1) else None)
    if math.isfinite(figure.limit_N):
        ax.axhline(figure.limit_N, color=GREY, linestyle=":", linewidth=1.0,
                   label=f"limit ({figure.limit_N:g} N)")
    ax.set_xlim(0.0, 100.0)
    ax.set_ylim(bottom=0.0)
    ax.set_xlabel("% of one repetition of the path")
    ax.set_ylabel("learned force along the path (N)")
    ax.legend(loc="center right", fontsize=7.5, frameon=False)
    _light_grid(ax)
    sheet.y_in += height + 0.5


def pose_plots(sheet: Sheet, figure: PoseFigure, x0: float, width: float) -> None:
    """Thesis Table 3.4 drawn: each ISB joint angle from the equation solver (solid) and
    the camera (dotted, broken where it saw nothing), then the shoulder's drift against
    the therapist's limit, then the comparison in words."""
    height = 2.1
    sheet.text("Joint angles (ISB): the equation solver against the camera", 10,
               weight="bold")
    sheet.gap(0.03)
    handles = [matplotlib.lines.Line2D([], [], color=c, linestyle=ls, linewidth=1.4, label=lb)
               for c, ls, lb in ((PURPLE, "-", "shoulder, solver"),
                                 (PURPLE, ":", "shoulder, camera"),
                                 (GREEN, "-", "elbow, solver"), (GREEN, ":", "elbow, camera"))]
    sheet.legend(handles, x0 - 0.55, ncols=4, size=7.5)
    sheet.gap(0.04)
    ax = sheet.axes(height, x_in=x0, width_in=width)
    for j, colour in enumerate((PURPLE, GREEN)):
        x, y = _thin(figure.t_s, np.degrees(figure.solver_isb_rad[:, j]), MAX_LINE_POINTS)
        ax.plot(x, y, color=colour, linewidth=1.2)
        x, y = _thin(figure.t_s, np.degrees(figure.camera_isb_rad[:, j]), MAX_LINE_POINTS)
        ax.plot(x, y, color=colour, linestyle=":", linewidth=1.4)
    ax.set_ylabel("angle (°)")
    ax.set_xlim(figure.t_s[0], figure.t_s[-1])
    _light_grid(ax)
    sheet.y_in += height + 0.42
    sheet.text("The shoulder's drift, seen by the camera (the solver assumes it still)", 10,
               weight="bold")
    sheet.gap(0.06)
    ax = sheet.axes(1.5, x_in=x0, width_in=width)
    x, y = _thin(figure.t_s, figure.drift_m * CM_PER_M, MAX_LINE_POINTS)
    ax.plot(x, y, color=BLUE, linewidth=1.2)
    if math.isfinite(figure.drift_limit_m):
        ax.axhline(figure.drift_limit_m * CM_PER_M, color=VERMILLION, linestyle="--",
                   linewidth=1.0)
    ax.set_ylim(bottom=0.0)
    ax.set_xlim(figure.t_s[0], figure.t_s[-1])
    ax.set_xlabel(TIME_LABEL)
    ax.set_ylabel("drift (cm)")
    _light_grid(ax)
    sheet.y_in += 1.5 + 0.5
    for line in figure.lines:
        sheet.text(line, 9)


def _joint_handles(figure: AnglesFigure | TorquesFigure) -> list:
    width = 1.4 if isinstance(figure, AnglesFigure) else 1.6
    return [matplotlib.lines.Line2D([], [], color=c, linestyle=ls, linewidth=width, label=label)
            for (c, ls), label in zip(_JOINT_STYLES, figure.labels, strict=True)]


def _plot_series(ax: Axes, figure: AnglesFigure | TorquesFigure) -> None:
    t = figure.t_s
    for column, (colour, style) in enumerate(_JOINT_STYLES):
        if isinstance(figure, AnglesFigure):
            x, y = _envelope(t, np.degrees(figure.isb_rad[:, column]))
            ax.plot(x, y, color=colour, linestyle=style, linewidth=1.4)
        else:
            x, y = _envelope(t, figure.raw_Nm[:, column])
            ax.plot(x, y, color=colour, linewidth=0.6, alpha=0.35)
            x, y = _envelope(t, figure.smoothed_Nm[:, column])
            ax.plot(x, y, color=colour, linestyle=style, linewidth=1.6)
    if isinstance(figure, AnglesFigure):
        ax.set_ylabel("angle (°)")
    else:
        ax.axhline(0.0, color=TARGET_GREY, linewidth=0.6, zorder=0)
        ax.set_ylabel("torque (N·m)")
    ax.set_xlim(t[0], t[-1])
    _light_grid(ax)


# -- drawing helpers -----------------------------------------------------------------------

def _light_grid(ax: Axes) -> None:
    ax.grid(True, color="#E6E6E6", linewidth=0.5)
    ax.set_axisbelow(True)


def _draw_runs(ax: Axes, x: np.ndarray, y: np.ndarray, runs: tuple[Run, ...], *,
               linewidth: float) -> None:
    """Within runs solid blue, outside runs dashed vermillion; one black line when
    there are no runs (no force or direction to judge by)."""
    if not runs:
        xs, ys = _envelope(x, y) if x.ndim == 1 and _is_time(x) else (x, y)
        ax.plot(xs, ys, color=INK, linewidth=linewidth, zorder=3)
        return
    budget = max(2, MAX_LINE_POINTS // max(1, len(runs)))
    for run in runs:
        part = slice(run.start, run.stop + 1)
        xs, ys = _thin(x[part], y[part], max(budget, int(MAX_LINE_POINTS * (run.stop + 1 -
                                                                            run.start)
                                                          / max(1, len(x)))))
        if run.within:
            ax.plot(xs, ys, color=BLUE, linewidth=linewidth, linestyle="-", zorder=3)
        else:
            ax.plot(xs, ys, color=VERMILLION, linewidth=linewidth, linestyle=(0, (3.5, 1.8)),
                    zorder=3)


def run_handles(runs: tuple[Run, ...], within: str, outside: str) -> list:
    """Legend entries for the within/outside lines; none without runs."""
    handles = []
    if runs:
        handles += [
            matplotlib.lines.Line2D([], [], color=BLUE, linewidth=1.6, label=within),
            matplotlib.lines.Line2D([], [], color=VERMILLION, linewidth=1.6,
                                    linestyle=(0, (3.5, 1.8)), label=outside),
        ]
    return handles


def _is_time(x: np.ndarray) -> bool:
    return x.size < 2 or bool(np.all(np.diff(x) >= 0))


def _thin(x: np.ndarray, y: np.ndarray, max_points: int) -> tuple[np.ndarray, np.ndarray]:
    """At most about `max_points` points, keeping each stretch's extremes (time series)
    or every k-th point (a path); the ends are always kept."""
    if x.size <= max_points:
        return x, y
    if _is_time(x):
        return _envelope(x, y, max_points)
    index = np.unique(np.r_[np.linspace(0, x.size - 1, max_points).astype(int), x.size - 1])
    return x[index], y[index]


def _envelope(t: np.ndarray, y: np.ndarray,
              max_points: int = MAX_LINE_POINTS) -> tuple[np.ndarray, np.ndarray]:
    """Min-max decimation: per bucket, the lowest and highest sample in time order, so
    a long trial's peaks (which set the ranges shown) survive the thinning."""
    n = t.size
    if n <= max_points:
        return t, y
    size = math.ceil(n / max(1, max_points // 2))
    buckets = math.ceil(n / size)
    padded = np.full(buckets * size, np.nan)
    padded[:n] = y
    padded = padded.reshape(buckets, size)
    missing = np.isnan(padded)
    base = np.arange(buckets) * size
    low = base + np.argmin(np.where(missing, np.inf, padded), axis=1)
    high = base + np.argmax(np.where(missing, -np.inf, padded), axis=1)
    index = np.unique(np.concatenate(([0, n - 1], np.minimum(low, n - 1),
                                      np.minimum(high, n - 1))))
    return t[index], y[index]
