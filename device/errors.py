"""The one exception family of `device`: everything that can go wrong talking to a robot.

A backend that fails raises one of these; the safety supervisor turns it into the
safe state and the window shows the message, so every message says what failed
and what the therapist or technician should do.
"""

from __future__ import annotations


class DeviceError(Exception):
    """Base of every error raised by `device`."""


class BackendError(DeviceError):
    """A robot backend failed: no answer, a driver error, or an unusable reading."""


class BackendTimeout(BackendError):
    """The backend did not answer in time."""


class BackendUnavailable(BackendError):
    """The backend's driver or hardware is not present on this machine."""


class SensorRangeError(BackendError):
    """A sensor reading is out of its physical range or not finite."""


class TareUnderLoad(BackendError):
    """The force sensor's zero at Connect was taken with a force on the handle."""


class StateError(DeviceError):
    """A command arrived in a state that does not allow it."""


class RecordingError(DeviceError):
    """The trial file could not be created, written or closed."""


class VideoError(DeviceError):
    """A trial's video cannot be used: missing, corrupt, empty, or not matching its
    timestamps or the trial."""


class PoseModelError(DeviceError):
    """The pose model cannot run here: not installed as the setup installs it, another
    OpenCV build in the way, or a model that would need a download."""
