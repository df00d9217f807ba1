"""An assessment trial's therapist table: the task's own figures first (core.assessment's
catalogue, in its order, in the units a person reads: app.units.shown), then the movement's
figures that are the patient's own; none measured against the trial's reference.

Why: a task is not an exercise along a path. Its reference runs on the task's clock (the
circle's dot, the targets' schedule) or is the robot's own move (position sense, strength),
which the task does not ask the patient to follow, so the distance from it, the push's
direction along it, the path's ratio to it and the reaches timed by it measure nothing of
the patient: the healthy virtual patient's reaching task read 33 / 31 mm "error" for
reaches whose own figures are all normal. The therapist's page showed those rows,
labelled as such, and the task's own figures only on the last page.
"""

from __future__ import annotations

from app.reports.compare import table_order
from app.reports.metrics_table import MetricRow, catalogue_row
from core.assessment import TASK_TITLES, task_figures
from core.holdtasks import ROBOT_TASKS

REFERENCE_KEYS = frozenset({
    "rmse_x_m", "rmse_y_m", "rmse", "directional_performance_pct", "path_length_ratio",
    "led_pct", "reaction_time_s", "initial_direction_error_rad"})
"""The therapist's rows measured against the trial's reference: the distance from it (x, y
and both), the push's direction along it, the hand's path over the reference's, keeping up
with it without help, and the reaches as the reference's targets time them
(core.reaches)."""
WHOLE_TRIAL_KEYS = frozenset({"mean_speed_m_s", "peak_speed_m_s", "movement_time_s", "sparc",
                              "ldlj"})
"""The movement's speed, time and smoothness over the whole trial, its pauses between a
task's movements included: the task measures them per movement (each reach's, each way
round the circle's) among its own figures, which the table shows instead."""
ROBOT_WORK_KEYS = frozenset({"robot_work_J", "robot_help_work_J"})
"""The robot's works, left out of a task the patient leads (reaching, circle, range): its
motors run the transparent law all through it and only make the robot lighter
(plain_language.robot_only_lightened), so its help is none by design and its net work its
own friction; the patient's net work stays. A task the robot leads keeps them."""


def task_rows(task: str) -> tuple[MetricRow, ...]:
    """The task's own figures as rows of the therapist's table."""
    title = TASK_TITLES.get(task, task)
    rows = []
    for figure in task_figures(task):
        better = f"; {figure.better} is better" if figure.better != "none" else ""
        rows.append(catalogue_row(figure, f"{title}'s own figure{better}"))
    return tuple(rows)


def task_order(task: str, mode: str) -> tuple[MetricRow, ...]:
    """An assessment trial's rows: `task_rows`, then `table_order(mode)`'s rows that are
    neither measured against the reference (REFERENCE_KEYS) nor measured by the task per
    movement (WHOLE_TRIAL_KEYS): the joints' ranges and torques, the forces, the works (the
    robot's only in a task it leads: ROBOT_WORK_KEYS)."""
    left_out = REFERENCE_KEYS | WHOLE_TRIAL_KEYS
    if task not in ROBOT_TASKS:
        left_out |= ROBOT_WORK_KEYS
    return task_rows(task) + tuple(row for row in table_order(mode) if row.key not in left_out)
