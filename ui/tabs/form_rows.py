"""The rows of a long form: a label, its field, and a place under the field for what is
wrong with it, in the field's own words (the Parameters tab's refusals are written under
the field to change)."""

from __future__ import annotations

from PySide6.QtWidgets import QFormLayout, QGroupBox, QLabel, QVBoxLayout, QWidget

from ui import theme


class FormRows:
    """Adds labelled rows to forms and keeps, by key, each row's label and problem line."""

    def __init__(self) -> None:
        self.errors: dict[str, QLabel] = {}
        self.labels: dict[str, QLabel] = {}

    @staticmethod
    def form(group: QGroupBox) -> QFormLayout:
        form = QFormLayout(group)
        form.setFieldGrowthPolicy(QFormLayout.FieldGrowthPolicy.AllNonFixedFieldsGrow)
        form.setRowWrapPolicy(QFormLayout.RowWrapPolicy.DontWrapRows)
        return form

    def add(self, form: QFormLayout, label: str, field: QWidget, key: str) -> QLabel:
        """A row `label: field` with a hidden problem line under the field; returns the
        problem line."""
        error = theme.set_role(QLabel(""), "problem")
        error.setWordWrap(True)
        error.hide()
        error.setAccessibleName(f"{label}: problem")
        self.errors[key] = error
        holder = QWidget()
        column = QVBoxLayout(holder)
        column.setContentsMargins(0, 0, 0, 0)
        column.setSpacing(2)
        column.addWidget(field)
        column.addWidget(error)
        form.addRow(label, holder)
        self.labels[key] = form.labelForField(holder)
        field.setAccessibleName(field.accessibleName() or label)
        return error
