"""The assessment battery's figures: the catalogue (core.assessment.figures) and
each task's figures as pure functions of recorded arrays."""

from core.assessment.figures import (
    CIRCLE_BASE_KEYS,
    CIRCLE_WAYS,
    FIGURES,
    STRENGTH_DIRECTIONS_DEG,
    TASK_TITLES,
    TASKS,
    FigureSpec,
    circle_key,
    figure,
    strength_key,
    task_figures,
)

__all__ = [
    "CIRCLE_BASE_KEYS",
    "CIRCLE_WAYS",
    "FIGURES",
    "STRENGTH_DIRECTIONS_DEG",
    "TASKS",
    "TASK_TITLES",
    "FigureSpec",
    "circle_key",
    "figure",
    "strength_key",
    "task_figures",
]
