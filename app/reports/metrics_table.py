"""A trial's metrics as a table for people: display units (mm, °, %), one line each,
with what the figure means. The same rows feed the terminal, the report and the window."""

from __future__ import annotations

import math
from dataclasses import dataclass

from app.units import MM_PER_M, MM_S_PER_M_S, shown
from core.metrics import TrialMetrics


@dataclass(frozen=True, slots=True)
class MetricRow:
    key: str  # TrialMetrics field
    label: str
    unit: str  # display unit
    scale: float  # SI value × scale = display value
    meaning: str
    short: str = ""  # a column heading
    decimals: int = -1  # the figure's decimals in a table; -1: its unit's (UNIT_DECIMALS)

    @property
    def places(self) -> int:
        """The decimals the figure is written with: as the window's tabs write it where
        they show it (0.9 mm, 31 %, 45.8°), never finer than the measurement means (a
        speed to the mm/s, not "130.36 mm/s")."""
        return self.decimals if self.decimals >= 0 else unit_places(self.unit)

    @property
    def heading(self) -> str:
        return self.short or self.label

    @property
    def label_in_unit(self) -> str:
        """The figure's name with its display unit, as a heading names it: 'Position
        error, x (RMSE) (mm)'; the name alone when it has no unit."""
        return _in_unit(self.label, self.unit)

    @property
    def heading_in_unit(self) -> str:
        """The short name with its display unit, as an axis or a chooser names it."""
        return _in_unit(self.heading, self.unit)


UNIT_DECIMALS = {"mm": 1, "%": 0, "°": 1, "mm/s": 0, "cm²": 0}
"""Display unit → decimals in the tables, as the Trajectory, Force and Joint angles tabs
and the patient's page write the same figures (ui.tabs: 0.9 mm, 31 %, 45.8°; an area
reached to the square centimetre, 412 cm²); any other unit two (N, N·m, J, s, ratios)."""


def unit_places(unit: str) -> int:
    """The decimals a figure shown in display `unit` is written with (UNIT_DECIMALS): the
    one rule of the report's rows, the Progress tab's table and the assessments' figures,
    so the same figure reads alike wherever it is."""
    return UNIT_DECIMALS.get(unit, 2)


def _in_unit(name: str, unit: str) -> str:
    return f"{name} ({unit})" if unit else name


ROWS: tuple[MetricRow, ...] = (
    MetricRow("rmse_x_m", "Position error, x (RMSE)", "mm", MM_PER_M,
              "how far the hand was from the path, sideways", short="RMSE x"),
    MetricRow("rmse_y_m", "Position error, y (RMSE)", "mm", MM_PER_M,
              "how far the hand was from the path, forward and back", short="RMSE y"),
    MetricRow("directional_performance_pct", "Directional performance", "%", 1.0,
              "share of the time the push pointed the way the path goes", short="Direction"),
    MetricRow("force_range_x_N", "Force range, x", "N", 1.0, "spread of the sideways push",
              short="Force range x"),
    MetricRow("force_range_y_N", "Force range, y", "N", 1.0, "spread of the forward push",
              short="Force range y"),
    MetricRow("shoulder_rom_rad", "Shoulder range of motion (ISB)", "°", 180.0 / math.pi,
              "how far the shoulder moved", short="Shoulder ROM"),
    MetricRow("elbow_rom_rad", "Elbow range of motion (ISB)", "°", 180.0 / math.pi,
              "how far the elbow moved", short="Elbow ROM"),
    MetricRow("shoulder_torque_range_Nm", "Shoulder torque range", "N·m", 1.0,
              "spread of the shoulder's effort (raw)", short="Shoulder torque"),
    MetricRow("elbow_torque_range_Nm", "Elbow torque range", "N·m", 1.0,
              "spread of the elbow's effort (raw)", short="Elbow torque"),
    MetricRow("shoulder_torque_range_smoothed_Nm", "Shoulder torque range, smoothed", "N·m",
              1.0, "the same after a 10 Hz zero-lag filter", short="Shoulder torque (10 Hz)"),
    MetricRow("elbow_torque_range_smoothed_Nm", "Elbow torque range, smoothed", "N·m", 1.0,
              "the same after a 10 Hz zero-lag filter", short="Elbow torque (10 Hz)"),
    MetricRow("path_length_ratio", "Path length ratio", "", 1.0,
              "hand's path over the target's (1 is ideal)", short="Path ratio"),
    MetricRow("mean_speed_m_s", "Mean speed", "mm/s", MM_S_PER_M_S, "while moving",
              short="Mean speed"),
    MetricRow("peak_speed_m_s", "Peak speed", "mm/s", MM_S_PER_M_S, "", short="Peak speed"),
    MetricRow("movement_time_s", "Movement time", "s", 1.0, "", short="Movement time"),
    MetricRow("sparc", "Smoothness (SPARC)", "", 1.0, "closer to 0 is smoother", short="SPARC"),
    MetricRow("ldlj", "Smoothness (LDLJ)", "", 1.0, "closer to 0 is smoother", short="LDLJ"),
    MetricRow("reaction_time_s", "Reaction time (mean)", "s", 1.0, "target shown to movement",
              short="Reaction time"),
    MetricRow("initial_direction_error_rad", "Initial direction error (mean)", "°",
              180.0 / math.pi, "first 100 ms against the line to the target",
              short="Initial dir. error"),
    MetricRow("led_pct", "Led the movement", "%", 1.0,
              "share of the time the patient kept up without the robot's help",
              short="Led"),
    MetricRow("robot_work_J", "Robot's net work", "J", 1.0,
              "what the motors put in (negative: held back); transparent: the robot's "
              "own friction",
              short="Robot work"),
    # not "Robot's help": the report's header, the Progress tab and the Parameters tab call
    # the assistance level (100 %) so, and the two sat in one report as 100 % and −0.22 J
    MetricRow("robot_help_work_J", "Work of the robot's help", "J", 1.0,
              "its pull on the hand, not its own friction (negative: against the hand)",
              short="Help's work"),
    MetricRow("patient_work_J", "Patient's net work", "J", 1.0,
              "what the hand put into the handle", short="Patient work"),
    MetricRow("robot_work_share", "Robot's share of the work", "%", 100.0,
              "help only, not its own friction; lower: patient did more", short="Robot share"),
    MetricRow("game_score", "Game score", "points", 1.0,
              "the game's points (core.games.scoring); a game trial only", short="Game score"),
    MetricRow("shoulder_elbow_correlation", "Shoulder–elbow correlation", "", 1.0,
              "how together the two joints moved", short="Shoulder–elbow r"),
)
ROW_BY_KEY: dict[str, MetricRow] = {row.key: row for row in ROWS}
"""The rows by their figure's key."""


def catalogue_row(figure, meaning: str) -> MetricRow:
    """An assessment task's figure (a core.assessment.FigureSpec, catalogued in SI) as a
    row in the unit a person reads it in (app.units.shown: a position error in mm, an
    angle in °; a ratio's or a count's unit none), wherever it is shown: the therapist's
    table, Progress, its PDF and `rehab progress` read the same figure in the same unit."""
    scale, unit = shown(1.0, figure.unit)
    return MetricRow(figure.key, figure.label, "" if unit in ("1", "count") else unit, scale,
                     meaning, short=figure.label)


def display_value(metrics: TrialMetrics | dict, row: MetricRow) -> float:
    """The row's figure in its display unit; NaN when the metrics have none (a game's score
    is no TrialMetrics field, and an exercise without a game has none)."""
    value = (metrics.get(row.key, math.nan) if isinstance(metrics, dict)
             else getattr(metrics, row.key, math.nan))
    return float(value) * row.scale


def number_text(value: float, decimals: int = 2) -> str:
    """A table figure: two decimals unless told (MetricRow.places), in the terminal's
    tables and the report's; one that rounds to zero reads 0.00, never "-0.00" (a help of
    −0.001 J is none, not a robot that held the hand back)."""
    if not math.isfinite(value):
        return "–"
    return f"{value if round(value, decimals) else 0.0:.{decimals}f}"


def format_metrics(metrics: TrialMetrics | dict, *, skip_missing: bool = True) -> str:
    lines = []
    for row in ROWS:
        value = display_value(metrics, row)
        if skip_missing and not math.isfinite(value):
            continue
        shown = f"{number_text(value, row.places):>9}"
        lines.append(f"  {row.label:<34}{shown} {row.unit:<5} {row.meaning}".rstrip())
    return "\n".join(lines)
