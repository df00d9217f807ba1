"""The Video tab (thesis Fig. A.5): what the camera sees, and whether it is recording.

Frames come from a `device.camera.capture.CameraSource`, which reads on its own thread;
this tab only picks up the newest frame at most 30 times a second while it is
visible, so a camera never slows the window. With *Show the pose* ticked, MediaPipe
Pose runs on the live frames on a worker thread of its own (`device.camera.live`) and
the arm's keypoints are drawn over the picture; the 2 ms loop, in its own process, never
waits for it. Opening a camera can take a
second, so it happens off the GUI thread. Without a camera the tab says how to
turn one on, instead of showing an empty picture.
"""

from __future__ import annotations

import itertools

import numpy as np
from PySide6.QtCore import QPointF, QSize, Qt, QTimer, Signal
from PySide6.QtGui import QColor, QImage, QPainter, QPen, QPixmap
from PySide6.QtWidgets import (
    QCheckBox,
    QLabel,
    QSizePolicy,
    QStackedLayout,
    QVBoxLayout,
    QWidget,
)

from app.pose.replay import ReplayVideo
from core.pose.keypoints import ELBOW, OTHER_SHOULDER, SHOULDER, WRIST
from device.camera.capture import CameraSource
from device.camera.detector import MediaPipePose
from device.camera.live import LivePose
from ui import plots, theme

POSE_COLOUR = theme.YELLOW  # over skin, cloth and a grey table alike
POSE_DOT_PX = 5

FRAME_INTERVAL_MS = 33  # ≤ 30 fps: the camera's own rate; faster would repaint copies

NO_CAMERA = (
    "<h2>No camera is in use</h2>"
    "<p>To film the session, open <b>Parameters</b>, choose <b>With camera</b>, and give "
    "the camera's number (<b>0</b> for the first camera plugged in) or a video file. "
    "The picture appears here, and the video is saved beside the trial.</p>"
    "<p>Without a camera the joint angles are worked out from the shoulder position, so "
    "the patient's shoulder must stay where it was measured.</p>"
)


class VideoTab(QWidget):
    """Signals: camera_opened(CameraSource), camera_failed(message)."""

    camera_opened = Signal(object)
    camera_failed = Signal(str)

    def __init__(self, parent=None) -> None:
        super().__init__(parent)
        self._camera: CameraSource | None = None
        self._shown_index = -1
        self._pending: object = None
        self.background = plots.Background(self)
        self.background.done.connect(self._opened)
        self.background.failed.connect(self._failed)

        self.message = QLabel(NO_CAMERA)
        self.message.setWordWrap(True)
        self.message.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.message.setMargin(40)
        self.picture = QLabel()
        self.picture.setAlignment(Qt.AlignmentFlag.AlignCenter)
        self.picture.setSizePolicy(QSizePolicy.Policy.Ignored, QSizePolicy.Policy.Ignored)
        self.picture.setMinimumSize(QSize(160, 120))
        self.picture.setStyleSheet("background: #111;")
        self.picture.setAccessibleName("Camera picture")
        self.state = theme.set_role(QLabel(""), "banner")
        self.state.setWordWrap(True)
        self.pose_box = QCheckBox("Show the pose: the arm's keypoints from the picture "
                                  "(MediaPipe, on this computer)")
        self.pose_box.setAccessibleName("Show the pose")
        self.pose_box.toggled.connect(self._pose_toggled)
        self.pose_side = "right"
        self._live: LivePose | None = None
        self._overlaid = 0
        self._replay: ReplayVideo | None = None
        self._replay_index = -1
        picture_page = QWidget()
        column = QVBoxLayout(picture_page)
        column.addWidget(self.picture, 1)
        column.addWidget(self.pose_box)
        column.addWidget(self.state)
        self.pages = QStackedLayout(self)
        self.pages.addWidget(self.message)
        self.pages.addWidget(picture_page)

        self.timer = QTimer(self)
        self.timer.setInterval(FRAME_INTERVAL_MS)
        self.timer.timeout.connect(self._tick)

    # -- public -------------------------------------------------------------------
    @property
    def camera(self) -> CameraSource | None:
        """The running camera, for the window to start and stop recording with the trial."""
        return self._camera

    def open_camera(self, source: int | str | None) -> None:
        """Open a camera number or video file off the GUI thread (None: no camera)."""
        self.close_camera()
        if source is None:
            return
        self._pending = source
        self.message.setText(f"<h2>Opening the camera…</h2><p>{source}</p>")
        self.background.submit(source, lambda: CameraSource(source).start())

    def set_camera(self, camera: CameraSource | None) -> None:
        """Show an already started camera (None: show how to enable one)."""
        if camera is not self._camera:
            self.close_camera()
        self._camera = camera
        self._shown_index = -1
        if camera is None:
            self.message.setText(NO_CAMERA)
            self.pages.setCurrentIndex(0)
            self.timer.stop()
            return
        self.pages.setCurrentIndex(1)
        if self.pose_box.isChecked():
            self._pose_toggled(True)
        self._update_state()
        if self.isVisible():
            self.timer.start()

    def close_camera(self) -> None:
        """Stop the camera this tab shows (and any recording it holds)."""
        self._stop_pose()
        replay, self._replay = self._replay, None
        if replay is not None:
            replay.close()
        self._pending = None
        camera, self._camera = self._camera, None
        self.timer.stop()
        if camera is not None:
            camera.stop()
        self.message.setText(NO_CAMERA)
        self.pages.setCurrentIndex(0)

    def shown_frames(self) -> int:
        """Index of the frame on screen, -1 before the first."""
        return self._shown_index

    @property
    def live_pose(self) -> LivePose | None:
        return self._live

    drawn_pose = None
    """The live pose result whose keypoints the picture shows now (None before any)."""

    def overlaid_frames(self) -> int:
        """How many pictures were shown with keypoints drawn over them."""
        return self._overlaid

    # -- live pose ----------------------------------------------------------------------
    def _pose_toggled(self, on: bool) -> None:
        self._stop_pose()
        if on and self._camera is not None:
            side = self.pose_side
            self._live = LivePose(self._camera, lambda: MediaPipePose(side, video=True)).start()
        self._update_state()

    def _stop_pose(self) -> None:
        live, self._live = self._live, None
        if live is not None:
            live.stop()

    def _draw_pose(self, pixmap: QPixmap, image_width: int) -> bool:
        live = self._live
        result = live.latest() if live is not None else None
        if result is None:
            return False
        _draw_keypoints(pixmap, image_width, result.keypoints.gapped())
        self.drawn_pose = result  # what the picture shows (the worker's latest may be newer)
        return True

    # -- replay -------------------------------------------------------------------------
    def show_replay(self, video: ReplayVideo | None) -> None:
        """Follow a replayed trial's video with the slider (None: no video for it). A live
        camera, if one is open, is shown again when the replay ends (close_replay)."""
        self.close_replay()
        self._replay = video
        if video is not None:
            self.timer.stop()
            self.pages.setCurrentIndex(1)
            self.state.setText(f"Replay of {video.name}: move the Replay tab's slider.")

    def close_replay(self) -> None:
        replay, self._replay = self._replay, None
        if replay is not None:
            replay.close()
            if self._camera is not None:
                self.set_camera(self._camera)
            else:
                self.pages.setCurrentIndex(0)

    def replayed_frame(self) -> int:
        """The replayed video's frame on screen, -1 when none."""
        return self._replay_index

    def seek(self, t: float) -> None:
        """Show the replayed video's frame taken at trial time t, with its keypoints."""
        replay = self._replay
        if replay is None:
            return
        frame = replay.frame_at(t)
        if frame is None:
            self.picture.clear()
            self._replay_index = -1
            self.state.setText(f"Replay of {replay.name}: no picture at {t:.2f} s.")
            return
        pixmap, width = self._scaled(frame.image)
        if frame.keypoints_px is not None:
            _draw_keypoints(pixmap, width, frame.keypoints_px)
        self.picture.setPixmap(pixmap)
        self._replay_index = frame.index
        pose = ("" if frame.keypoints_px is not None
                else " (no pose yet: Replay tab, Joint angles from the video)")
        self.state.setText(f"Replay of {replay.name}: frame {frame.index} at "
                           f"{frame.time_s:.2f} s{pose}.")

    # -- showing frames -------------------------------------------------------------
    def showEvent(self, event) -> None:
        super().showEvent(event)
        if self._camera is not None and self._replay is None:
            self.timer.start()

    def hideEvent(self, event) -> None:
        super().hideEvent(event)
        self.timer.stop()

    def closeEvent(self, event) -> None:
        self.close_camera()
        super().closeEvent(event)

    def _tick(self) -> None:
        camera = self._camera
        if camera is None or self._replay is not None:
            return
        frame = camera.latest()
        if frame is not None and frame.index != self._shown_index:
            pixmap, width = self._scaled(frame.image)
            if self._draw_pose(pixmap, width):
                self._overlaid += 1
            self.picture.setPixmap(pixmap)
            self._shown_index = frame.index
        self._update_state()

    def _scaled(self, image: np.ndarray) -> tuple[QPixmap, int]:
        """A camera's or a replayed video's BGR frame as a pixmap the picture's size
        (aspect kept), with the frame's own width in pixels (the keypoints' scale)."""
        height, width = image.shape[:2]
        qimage = QImage(image.data, width, height, image.strides[0],
                        QImage.Format.Format_BGR888)
        pixmap = QPixmap.fromImage(qimage).scaled(
            self.picture.size(), Qt.AspectRatioMode.KeepAspectRatio,
            Qt.TransformationMode.SmoothTransformation)
        return pixmap, width

    def _update_state(self) -> None:
        camera = self._camera
        if camera is None:
            return
        if camera.error:
            text = f"{theme.PROBLEM_SIGN} {camera.error}"
        elif camera.recording:
            text = (f"● Recording to {camera.recording_path.name}: {camera.recorded_frames} "
                    f"frames at {camera.fps:.0f} per second")
        elif camera.ended:
            text = f"{camera.description}: end of the video. Not recording."
        else:
            text = (f"{camera.description}, {camera.frame_size[0]}×{camera.frame_size[1]} at "
                    f"{camera.fps:.0f} frames per second. Not recording: recording starts "
                    "with the trial.")
        live = self._live
        if live is not None:
            if live.error:
                text += f" {theme.PROBLEM_SIGN} {live.error}"
            elif live.latest() is None:
                text += " Pose: starting the model…"
            elif np.isnan(live.latest().keypoints.gapped()[:OTHER_SHOULDER]).all():
                # nothing drawn and a rate alone read as working: say the arm is not seen
                text += (f" {theme.PROBLEM_SIGN} Pose: no arm in view (the model looks at "
                         f"{live.rate_fps:.0f} pictures a second); turn the camera to the arm.")
            else:
                text += f" Pose: {live.rate_fps:.0f} pictures a second."
            if live.give_way_problems and not live.error:
                text += f" {theme.PROBLEM_SIGN} {live.give_way_problems[0]}"
        if self.state.text() != text:
            self.state.setText(text)

    # -- opening off the GUI thread ---------------------------------------------------
    def _opened(self, token, camera: CameraSource) -> None:
        if token != self._pending:
            camera.stop()  # superseded while it opened
            return
        self._pending = None
        self.set_camera(camera)
        self.camera_opened.emit(camera)

    def _failed(self, token, message: str) -> None:
        if token != self._pending:
            return
        self._pending = None
        self.message.setText(f"<h2>{theme.PROBLEM_SIGN} The camera cannot be used</h2>"
                             f"<p>{message}</p>{NO_CAMERA.split('</h2>', 1)[1]}")
        self.pages.setCurrentIndex(0)
        self.camera_failed.emit(message)



def _draw_keypoints(pixmap: QPixmap, image_width: int, points) -> None:
    """The arm's keypoints (4, 2) in the picture's pixels (gaps NaN) over its scaled copy:
    the shoulders joined, the arm as a chain, a dot on each."""
    scale = pixmap.width() / image_width
    painter = QPainter(pixmap)
    painter.setRenderHint(QPainter.RenderHint.Antialiasing)
    painter.setPen(QPen(QColor(POSE_COLOUR), 3))
    painter.setBrush(QColor(POSE_COLOUR))
    chain = [np.asarray(points[i], dtype=float) * scale
             for i in (OTHER_SHOULDER, SHOULDER, ELBOW, WRIST)]
    for a, b in itertools.pairwise(chain):
        if np.isfinite(a).all() and np.isfinite(b).all():
            painter.drawLine(QPointF(float(a[0]), float(a[1])),
                             QPointF(float(b[0]), float(b[1])))
    for p in chain:
        if np.isfinite(p).all():
            painter.drawEllipse(QPointF(float(p[0]), float(p[1])), POSE_DOT_PX, POSE_DOT_PX)
    painter.end()
