"""The Human joint angles tab (thesis Fig. 3.11, A.4): the shoulder and elbow angles in
the ISB convention (eq. 3.37–3.38), in degrees over the exercise, with each joint's
range of motion: how far the patient's arm moved, for the therapist to tailor the
next exercise.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from PySide6.QtWidgets import QFileDialog, QLabel, QPushButton, QWidget

from ui import plots, theme
from ui.jobs import Jobs
from ui.views.numbers import format_number
from ui.views.trialview import TrialView

JOINTS = ("shoulder", "elbow")
NO_POSE = ("No camera angles for this trial. With a video recorded beside it, the "
           "Replay tab's Joint angles from the video adds them here beside the solver's.")


class AnglesTab(QWidget):
    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._view: TrialView | None = None
        self._drawn: tuple = ()
        self.plot = plots.make_plot("time (s)", "angle (°, ISB)")
        item = self.plot.getPlotItem()
        self.curves = plots.joint_curves(item)
        # the camera's angles (rehab pose), beside the solver's: lighter, dotted
        self.camera_curves = [
            plots.curve(item, theme.SKY_BLUE, dashed=True, name="shoulder, camera", gaps=True),
            plots.curve(item, theme.VERMILLION, dashed=True, name="elbow, camera",
                        gaps=True),
        ]
        # named in the legend only while drawn: "shoulder, camera" stood in the legend of
        # every trial, over a note saying the trial had no camera angles
        self._camera_in_legend(False)
        self.cursor_line = plots.cursor_line(item)
        self.rom = [plots.BigNumber(f"{joint.capitalize()} range of motion", "°")
                    for joint in JOINTS]
        note = theme.set_role(QLabel(
            "Angles as the International Society of Biomechanics defines them (thesis eq. "
            "3.37–3.38). The elbow angle is 0° with the arm straight and grows as it bends."),
            "caption")
        note.setWordWrap(True)
        self.camera_note = theme.set_role(QLabel(NO_POSE), "caption")
        self.camera_note.setWordWrap(True)
        self.camera_note.setAccessibleName("Camera against the solver")
        # Table 3.4's own validation as a tool: the solver and the camera against a
        # goniometer's or a motion-capture system's angles (core.pose.compare's CSV)
        self.files_folder = ""
        """Where the reference's file dialog starts: the patient's trials (ui.main_window)."""
        self.reference_button = QPushButton("Compare with reference angles…")
        self.reference_button.setToolTip(
            "A CSV with a header frame or time_s, shoulder_deg, elbow_deg (ISB angles, as a "
            "goniometer reads them); for a trial whose joint angles from the video were "
            "found (Replay tab)")
        self.reference_button.clicked.connect(self.choose_reference)
        self.reference_button.setEnabled(False)
        self.reference_note = theme.set_role(QLabel(""), "caption")
        self.reference_note.setWordWrap(True)
        self.reference_note.setAccessibleName("Against the reference angles")
        self.jobs = Jobs(self)
        self.jobs.failed.connect(self._reference_failed)
        plots.plot_with_panel(self, self.plot, self.rom,
                              (note, self.camera_note, self.reference_button,
                               self.reference_note))

    def show_view(self, view: TrialView) -> None:
        state = (id(view), view.n)
        if view is self._view and state == self._drawn:
            plots.place_cursor(self.cursor_line, view.cursor)
            return
        self._view = view
        self._drawn = state
        ex = view.exercise
        t = view.time[ex]
        angles = np.degrees(view.column("subject_angle_isb")[:, ex])
        for j, line in enumerate(self.curves):
            line.setData(t, angles[j])
        low, high = (np.degrees(v) for v in view.range_of("subject_angle_isb"))
        for j, number in enumerate(self.rom):
            number.set_value(high[j] - low[j], f"from {format_number(low[j])}° to "
                                               f"{format_number(high[j])}°")
        pose = view.pose
        self._camera_in_legend(pose is not None)
        if pose is None:
            for line in self.camera_curves:
                line.setData([], [])
            self.camera_note.setText(NO_POSE)
        else:
            keep = (pose.time_s >= t[0]) & (pose.time_s <= t[-1]) if t.size else pose.time_s < 0
            camera = np.degrees(pose.angle_isb_rad[keep])
            for j, line in enumerate(self.camera_curves):
                # gaps stay gaps: pyqtgraph breaks the line at NaN
                line.setData(pose.time_s[keep], camera[:, j])
            self.camera_note.setText(pose.comparison_text())
        self.reference_button.setEnabled(pose is not None and view.source is not None)
        plots.place_cursor(self.cursor_line, view.cursor)

    def legend_names(self) -> list[str]:
        """The names the plot's legend shows, in order."""
        return [label.text for _sample, label in self.plot.getPlotItem().legend.items]

    def _camera_in_legend(self, shown: bool) -> None:
        legend = self.plot.getPlotItem().legend
        for line in self.camera_curves:
            if shown and legend.getLabel(line) is None:
                legend.addItem(line, line.name())
            elif not shown and legend.getLabel(line) is not None:
                legend.removeItem(line)

    def choose_reference(self) -> None:
        path, _ = QFileDialog.getOpenFileName(self, "Reference angles", self.files_folder,
                                              "CSV files (*.csv);;All files (*)")
        if path:
            self.compare_reference(Path(path))

    def compare_reference(self, reference: Path) -> None:
        """The solver and the camera against the angles in `reference`, on the job
        thread; the result (or why not) in the panel."""
        from app.pose.offline import compare_with_reference, reference_lines

        view = self._view
        if view is None or view.source is None:
            return
        trial = Path(view.source)
        self.reference_note.setText(f"Comparing with {reference.name}…")
        theme.switch_role(self.reference_note, "caption")
        self.jobs.run(lambda: reference_lines(compare_with_reference(trial, reference)),
                      lambda lines: self._show_reference(reference, lines))

    def _show_reference(self, reference: Path, lines: list[str]) -> None:
        self.reference_note.setText(f"Against {reference.name} (other − reference):\n"
                                    + "\n".join(lines))

    def _reference_failed(self, error: Exception) -> None:
        theme.switch_role(self.reference_note, "problem")
        self.reference_note.setText(f"{theme.PROBLEM_SIGN} {error}")

    def set_cursor(self, t: float | None) -> None:
        if self._view is not None:
            self._view.cursor = t
            plots.place_cursor(self.cursor_line, self._view.cursor)
