"""The Replay tab: open any past trial (from the patient's list or a file), then move
through it with a slider or play it back; every other tab follows the cursor.

Reading a trial file is disk work, so it happens off the GUI thread; the loaded
trial arrives as a `TrialView` (view_loaded), and each move of the slider as a
time in the trial (cursor_moved). The window hands both to the other tabs.

A trial opened from the list is first found in the registry, on the window's job thread
(ui.jobs), as the Assessments tab reads its figures: on the window's thread a slow or
silent shared registry froze the window for its bounded wait. The tab says "Loading…"
meanwhile; an answer no longer wanted (another trial or a file opened since, another
patient listed, the window closing) is dropped; closing does not wait for it. Each row
holds its file's path from the listing, so marking the trial shown reads nothing.
"""

from __future__ import annotations

import contextlib
from pathlib import Path

from PySide6.QtCore import Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QComboBox,
    QFileDialog,
    QFormLayout,
    QGroupBox,
    QHBoxLayout,
    QLabel,
    QListWidget,
    QListWidgetItem,
    QProgressBar,
    QPushButton,
    QSlider,
    QVBoxLayout,
    QWidget,
)

from app.errors import AppError
from app.pose.replay import ReplayVideo
from app.records.registry import Trial
from app.records.store import RecordStore
from app.records.trialplace import file_to_read
from app.trials.reader import read_trial
from ui import plots, theme
from ui.jobs import Jobs
from ui.views.moment import MOMENT_ROWS, describe_trial, moment
from ui.views.trialview import TrialView

LOADING = "Loading…"


class _NotHere(Exception):
    """The trial's file cannot be read on this station (app.records.trialplace says why:
    on the station that recorded it, not yet in the trial store; its store's copy not the
    file recorded …): said as it is, not as a registry problem."""


PATH_ROLE = Qt.ItemDataRole.UserRole + 1
"""A row's trial file (its id is in UserRole)."""
PLAY_INTERVAL_MS = 40
SPEEDS = (0.25, 0.5, 1.0, 2.0, 4.0)


def pose_then_view(path: Path, progress, registry: RecordStore | None = None) -> TrialView:
    """Pose estimation of a trial's video into its file (app.pose.offline, MediaPipe), then
    the trial read again with it (runs off the GUI thread). A registered trial's file
    keeps its new checksum in `registry` (app.trials.rewrite)."""
    from app.pose.offline import estimate_pose
    from app.trials.rewrite import rewriting_files
    from device.camera.detector import MediaPipePose

    with (rewriting_files(registry, [path], "the camera's pose") if registry is not None
          else contextlib.nullcontext()):
        estimate_pose(path, lambda side: MediaPipePose(side, video=True), progress=progress)
    return load_view(path)


def load_view(path: Path) -> TrialView:
    """Read a trial file into a finished view, with its video when one was recorded (runs
    off the GUI thread)."""
    data = read_trial(path)
    view = TrialView.from_trial(data)
    view.video = ReplayVideo.open(data)  # its video, to follow the slider (None without)
    code = data.subject.code if data.subject is not None else "unknown patient"
    view.title = f"{code} · {path.name}"
    return view


class ReplayTab(QWidget):
    """Signals: view_loaded(TrialView), cursor_moved(t in s), load_failed(message)."""

    view_loaded = Signal(object)
    cursor_moved = Signal(float)
    load_failed = Signal(str)

    def __init__(self, registry: RecordStore | None = None, parent=None, *,
                 jobs: Jobs | None = None) -> None:
        super().__init__(parent)
        self.registry = registry
        # the window's job thread (registry calls one after another); a tab on its own
        # has its own
        self.jobs = jobs if jobs is not None else Jobs(self)
        self._asked: object | None = None  # the registry read of a trial to open, waited for
        self.files_folder = ""
        """Where Open file… starts: the chosen patient's trials (ui.main_window)."""
        self._code: str | None = None
        self._view: TrialView | None = None
        self._loading: Path | None = None
        self._numbers: dict[Path, tuple[int, int]] = {}  # a registered file's (session, trial)
        # a trial read from the trial store: (its copy, the note, its row's path, the
        # station that recorded it)
        self._from_store: tuple[Path, str, Path | None, str] | None = None
        """The trial being opened from the shared trial store: its copy, the note saying
        so, and its row's path (its data folder's)."""
        self.background = plots.Background(self)
        self.background.done.connect(self._loaded)
        self.background.failed.connect(self._failed)

        self.trials = QListWidget()
        self.trials.setAccessibleName("Trials of this patient")
        # each trial two lines (ui.views.moment.describe_trial), wrapped and never cut with
        # "…" at a large font: an assessment's name is the longest
        self.trials.setWordWrap(True)
        self.trials.setSpacing(3)
        self.trials.itemActivated.connect(self._open_item)
        self.open_selected = theme.set_role(QPushButton("Open selected trial"), "primary")
        self.open_selected.clicked.connect(self._open_current)
        self.open_other = QPushButton("Open file…")
        self.open_other.clicked.connect(self._choose_file)
        self.list_heading = theme.set_role(QLabel("Trials"), "heading")
        left = QVBoxLayout()
        left.addWidget(self.list_heading)
        left.addWidget(self.trials, 1)
        buttons = QHBoxLayout()
        buttons.addWidget(self.open_selected)
        buttons.addWidget(self.open_other)
        left.addLayout(buttons)

        self.title = theme.set_role(QLabel("No trial open"), "heading")
        self.title.setWordWrap(True)
        self.info = theme.set_role(QLabel("Choose a trial on the left, or open a file."),
                                   "caption")
        self.info.setWordWrap(True)
        self.slider = QSlider(Qt.Orientation.Horizontal)
        self.slider.setAccessibleName("Moment in the trial")
        self.slider.setEnabled(False)
        self.slider.valueChanged.connect(self._slid)
        self.time_label = theme.set_role(QLabel("–"), "lead")
        self.play = QPushButton("Play")
        self.play.setCheckable(True)
        self.play.setEnabled(False)
        self.play.toggled.connect(self._play_toggled)
        self.speed = QComboBox()
        for speed in SPEEDS:
            self.speed.addItem(f"{speed:g}×", speed)
        self.speed.setCurrentIndex(SPEEDS.index(1.0))
        self.speed.setAccessibleName("Playback speed")
        controls = QHBoxLayout()
        controls.addWidget(self.play)
        controls.addWidget(self.speed)
        controls.addWidget(self.time_label, 1)
        right = QVBoxLayout()
        right.addWidget(self.title)
        right.addWidget(self.info)
        right.addSpacing(12)
        right.addWidget(self.slider)
        right.addLayout(controls)
        right.addWidget(theme.set_role(QLabel(
            "Move the slider, or press Play: every tab shows the trial at that moment."),
            "caption"))
        self.pose_button = QPushButton("Joint angles from the video")
        self.pose_button.setToolTip("Pose estimation of this trial's video (MediaPipe): the "
                                    "camera's angles beside the solver's on the Joint angles "
                                    "tab, and the shoulder's drift")
        self.pose_button.setEnabled(False)
        self.pose_button.clicked.connect(self.run_pose)
        self.pose_progress = QProgressBar()
        self.pose_progress.setRange(0, 100)
        self.pose_progress.setAccessibleName("Pose estimation progress")
        self.pose_progress.hide()
        self.pose_status = theme.set_role(QLabel(""), "caption")
        self.pose_status.setWordWrap(True)
        pose_row = QHBoxLayout()
        pose_row.addWidget(self.pose_button)
        pose_row.addWidget(self.pose_progress, 1)
        right.addLayout(pose_row)
        right.addWidget(self.pose_status)
        self.pose_job = plots.Background(self)
        self.pose_job.done.connect(self._pose_done)
        self.pose_job.failed.connect(self._pose_failed)
        self._pose_fraction = 0.0
        self._loading_after_pose: Path | None = None
        self.pose_timer = QTimer(self)
        self.pose_timer.setInterval(100)
        self.pose_timer.timeout.connect(
            lambda: self.pose_progress.setValue(round(100 * self._pose_fraction)))
        right.addSpacing(12)
        moment = QGroupBox("At this moment")
        form = QFormLayout(moment)
        self.moment: dict[str, QLabel] = {}
        for key, label in MOMENT_ROWS:
            value = QLabel("–")
            value.setWordWrap(True)
            self.moment[key] = value
            form.addRow(theme.set_role(QLabel(label), "caption"), value)
        right.addWidget(moment)
        right.addStretch(1)

        layout = QHBoxLayout(self)
        layout.addLayout(left, 2)
        layout.addLayout(right, 3)

        self.timer = QTimer(self)
        self.timer.setInterval(PLAY_INTERVAL_MS)
        self.timer.timeout.connect(self._advance)

    # -- choosing a trial ------------------------------------------------------------
    @property
    def view(self) -> TrialView | None:
        return self._view

    def set_registry(self, registry: RecordStore) -> None:
        self.registry = registry

    def set_patient(self, code: str | None, trials: list[Trial] | None = None) -> None:
        """List this patient's trials from the registry (None: clear the list); `trials`:
        theirs as read on the window's job thread (ui.window.after_trial), else read here.
        A trial being found for the same patient still opens (its id is the same)."""
        if code != self._code:
            self._drop_opening()  # another patient's trial: not opened now
        self._code = code
        self.trials.clear()
        if code is None or self.registry is None:
            self.list_heading.setText("Trials")
            return
        self.list_heading.setText(f"Trials of {code}")
        if trials is None:
            trials = self.registry.trials_for_patient(code)
        for trial in reversed(trials):
            item = QListWidgetItem(describe_trial(trial, self.registry.station))
            item.setData(Qt.ItemDataRole.UserRole, trial.id)
            # no registry read (a Trial); a stored path outside the data folder is left
            # out, opening the row says why
            with contextlib.suppress(AppError):
                item.setData(PATH_ROLE, self.registry.trial_path(trial))
            self.trials.addItem(item)
        if self.trials.count():
            self.trials.setCurrentRow(0)

    def show_loading(self, code: str) -> None:
        """Patient `code`'s trials being read (on the window's job thread): the list
        empty meanwhile (an id it held may no longer be the trial's: a station's sync
        gives its trials the server's), its heading saying "Loading…". A trial being found
        by an id from before is not opened, and the tab says so."""
        self._drop_opening()
        self._code = code
        self.trials.clear()
        self.list_heading.setText(f"Trials of {code}: {LOADING}")

    def open_file(self, path: str | Path) -> None:
        """Load a trial file off the GUI thread; view_loaded or load_failed follows."""
        path = Path(path)
        self._asked = None  # a trial being found in the registry: not opened now
        self._from_store = None
        self._loading = path
        self.play.setChecked(False)
        self.info.setText(f"Opening {path.name}…")
        self.background.submit(path, load_view, path)

    def _open_item(self, item: QListWidgetItem) -> None:
        """Find the row's trial file in the registry on the job thread, then open it."""
        if self.registry is None:
            return
        registry, trial_id = self.registry, item.data(Qt.ItemDataRole.UserRole)
        asked = self._asked = object()
        self.play.setChecked(False)
        self.info.setText(f"{LOADING} finding the trial in the registry.")

        def read() -> tuple[Path, str, tuple[int, int]] | Exception:
            try:
                trial = registry.trial(trial_id)
            except Exception as exc:  # the registry gone, the trial unknown: said, not raised
                return exc
            try:  # its data folder's file, else the trial store's copy, checked
                path, note = file_to_read(registry, trial)
            except AppError as exc:
                return _NotHere(str(exc))
            return path, note, (trial.session_number, trial.number), trial.station

        def answered(found: tuple[Path, str, tuple[int, int], str | None] | Exception
                     ) -> None:
            if self.jobs.closed or self._asked is not asked:
                return  # the window closed, or another trial, file or patient since
            self._asked = None
            if isinstance(found, Exception):
                said = str(found)
                message = (f"{said[:1].upper()}{said[1:]}." if isinstance(found, _NotHere) else
                           f"The trial could not be read from the registry: {found}. "
                           "Open it again.")
                self.info.setText(f"{theme.PROBLEM_SIGN} {message}")
                self.load_failed.emit(message)
                return
            path, note, self._numbers[path], station = found
            self.open_file(path)
            if note:  # the store's copy: said once it is shown, and it marks its row
                self._from_store = (path, note, item.data(PATH_ROLE), station or "")

        self.jobs.run(read, answered)

    def opening(self) -> bool:
        """A trial of the list is being found in the registry."""
        return self._asked is not None

    def drop_opening(self) -> bool:
        """The window closes: the trial being found is not waited for (its answer is
        dropped, the job thread ending after it). True when one was."""
        asked, self._asked = self._asked, None
        return asked is not None

    def _drop_opening(self) -> None:
        """The list is read again: a trial being found by its row's id is not opened (the
        id may no longer be the trial's), and the tab says so where it said "Loading…"."""
        if self.drop_opening():
            self.info.setText("The list of trials is being read again: choose the trial "
                              "again once it is shown.")

    def _open_current(self) -> None:
        item = self.trials.currentItem()
        if item is not None:
            self._open_item(item)

    def _choose_file(self) -> None:
        # the patient's folder of the data folder (the window sets it), not the program's
        start = self.files_folder or (str(self.registry.data_dir.trials_dir)
                                      if self.registry is not None else "")
        path, _ = QFileDialog.getOpenFileName(self, "Open a trial", start,
                                              "Trial files (*.h5);;All files (*)")
        if path:
            self.open_file(path)

    def _loaded(self, path, view: TrialView) -> None:
        if path != self._loading:
            return
        self._loading = None
        self._view = view
        view.numbers = self._numbers.get(Path(path))
        self.title.setText(view.title)
        data_notes = "" if view.finished else " The file was not closed; showing what it holds."
        stored = self._from_store if self._from_store is not None \
            and self._from_store[0] == path else None
        if stored is not None:
            data_notes += f" {stored[1][0].upper()}{stored[1][1:]}."
        self.info.setText(f"{view.duration_s:.1f} s, {view.n} samples.{data_notes}")
        self.slider.blockSignals(True)
        self.slider.setRange(0, max(view.n - 1, 0))
        self.slider.setValue(0)
        self.slider.setEnabled(view.n > 1)
        self.slider.blockSignals(False)
        self.play.setEnabled(view.n > 1)
        view.cursor = float(view.time[0]) if view.n else None
        self._show_time()
        has_video = view.video is not None and view.finished and view.source is not None
        # the store's copy is the recording station's proven file: never written into here
        self.pose_button.setEnabled(has_video and stored is None and not self.pose_job.busy)
        if stored is not None:
            # the store keeps trial files, never videos; neither the file nor the registry
            # says whether the station filmed the trial ("No video was recorded" said so of
            # a trial whose video was on its station)
            at = f"station {stored[3]}" if stored[3] else "the station that recorded it"
            self.pose_status.setText(
                "Opened from the trial store, which keeps trial files, not videos: a video "
                f"of this trial, if one was recorded, is at {at}, and its joint angles from "
                "the video are found there.")
        elif not has_video:
            self.pose_status.setText("No video beside this trial's file: none was recorded "
                                     "with it, or it was not copied with the file.")
        elif self._loading_after_pose is not path:
            self.pose_status.setText("")
        self._mark_in_list(Path(stored[2]) if stored is not None and stored[2] is not None
                           else Path(path))
        self.view_loaded.emit(view)

    def _mark_in_list(self, path: Path) -> None:
        """The list marks the trial shown, never another (it kept its first row marked
        over a trial opened with Open file…); a file not of this list marks nothing."""
        shown = None
        for row in range(self.trials.count()):
            here = self.trials.item(row).data(PATH_ROLE)
            if here is not None and Path(here).resolve() == path.resolve():
                shown = row
                break
        if shown is None:
            self.trials.clearSelection()
            self.trials.setCurrentRow(-1)
        else:
            self.trials.setCurrentRow(shown)

    # -- pose estimation of the trial's video ------------------------------------------
    def run_pose(self) -> None:
        """Run pose estimation on the open trial's video off the GUI thread, with progress;
        the trial is shown again with the camera's angles when it is done."""
        view = self._view
        if view is None or view.source is None or self.pose_job.busy:
            return
        self._pose_fraction = 0.0
        self.pose_progress.setValue(0)
        self.pose_progress.show()
        self.pose_button.setEnabled(False)
        self.pose_status.setText(f"Finding the arm in {view.video.name}…")
        self.pose_timer.start()

        def progress(fraction: float) -> None:
            self._pose_fraction = fraction  # read by the GUI thread's timer

        self.pose_job.submit(view.source, pose_then_view, view.source, progress,
                            self.registry)

    def _pose_done(self, path, view: TrialView) -> None:
        self.pose_timer.stop()
        self.pose_progress.hide()
        pose = view.pose
        self.pose_status.setText(
            "Done: the camera's angles are on the Joint angles tab." if pose is not None
            else "Done.")
        self._loading = path
        self._loading_after_pose = path
        self._loaded(path, view)
        self._loading_after_pose = None

    def _pose_failed(self, path, message: str) -> None:
        self.pose_timer.stop()
        self.pose_progress.hide()
        self.pose_button.setEnabled(self._view is not None and self._view.video is not None)
        self.pose_status.setText(f"{theme.PROBLEM_SIGN} {message}")

    def _failed(self, path, message: str) -> None:
        if path != self._loading:
            return
        self._loading = None
        self.info.setText(f"{theme.PROBLEM_SIGN} {message}")
        self.load_failed.emit(message)

    # -- the cursor ------------------------------------------------------------------
    def set_cursor(self, t: float) -> None:
        """Move to time t (s) without emitting cursor_moved (the caller knows)."""
        if self._view is None or self._view.n == 0:
            return
        self._view.cursor = t
        self.slider.blockSignals(True)
        self.slider.setValue(self._view.current_index)
        self.slider.blockSignals(False)
        self._show_time()

    def _slid(self, index: int) -> None:
        view = self._view
        if view is None or view.n == 0:
            return
        t = float(view.time[min(index, view.n - 1)])
        view.cursor = t
        self._show_time()
        self.cursor_moved.emit(t)

    def _show_time(self) -> None:
        view = self._view
        if view is None or view.cursor is None:
            self.time_label.setText("–")
            for value in self.moment.values():
                value.setText("–")
            return
        elapsed = view.cursor - float(view.time[0])
        self.time_label.setText(f"{elapsed:.1f} s of {view.duration_s:.1f} s")
        for key, text in moment(view, view.current_index).items():
            self.moment[key].setText(text)

    def _play_toggled(self, on: bool) -> None:
        self.play.setText("Pause" if on else "Play")
        if on and self._view is not None:
            if self.slider.value() >= self.slider.maximum():
                self.slider.setValue(0)
            self.timer.start()
        else:
            self.timer.stop()

    def _advance(self) -> None:
        view = self._view
        if view is None or view.cursor is None:
            self.play.setChecked(False)
            return
        step = PLAY_INTERVAL_MS / 1000.0 * self.speed.currentData()
        target = view.cursor + step
        if target >= float(view.time[-1]):
            self.slider.setValue(self.slider.maximum())
            self.play.setChecked(False)
            return
        self.slider.setValue(max(view.index_at(target), self.slider.value() + 1))
