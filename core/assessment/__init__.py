"""The assessment battery's figures: the catalogue (core.assessment.figures) and
each task's figures as pure functions of recorded arrays."""

from core.assessment.figures import (
    FIGURES,
    STRENGTH_DIRECTIONS_DEG,
    TASK_TITLES,
    TASKS,
    FigureSpec,
    figure,
    strength_key,
    task_figures,
)

__all__ = [
    "FIGURES",
    "STRENGTH_DIRECTIONS_DEG",
    "TASKS",
    "TASK_TITLES",
    "FigureSpec",
    "figure",
    "strength_key",
    "task_figures",
]
