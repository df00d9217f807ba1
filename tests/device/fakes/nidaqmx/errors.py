"""Fake of `nidaqmx.errors` (1.7.0): same classes, hierarchy, messages and properties.

Note the hierarchy: `DaqNotFoundError` (no driver installed) derives from `Error`,
not from `DaqError`, so `except DaqError` does not catch it.
"""

import warnings

from nidaqmx.error_codes import DAQmxErrors, DAQmxWarnings

__all__ = ["DaqError", "DaqReadError", "DaqResourceWarning", "DaqWarning"]


class Error(Exception):
    """Base error class for module."""


class DaqNotFoundError(Error):
    """Error raised when NI-DAQmx driver is not installed."""


class DaqNotSupportedError(Error):
    """Error raised when DAQmx is not supported on this platform."""


class DaqFunctionNotSupportedError(Error):
    """Error raised when a specific function isn't supported by the installed NI-DAQmx driver."""


class DaqError(Error):
    """Error raised by any DAQmx method."""

    def __init__(self, message, error_code, task_name=""):
        self._error_code = int(error_code)
        try:
            self._error_type = DAQmxErrors(self._error_code)
        except ValueError:
            self._error_type = DAQmxErrors.UNKNOWN
        if not message:
            message = (
                "Description could not be found for the status code.\n\n"
                f"Status Code: {self._error_code}"
            )
        if task_name:
            message = f"{message}\n\nTask Name: {task_name}"
        if str(self._error_code) not in message:
            message = f"{message}\n\nStatus Code: {self._error_code}"
        super().__init__(message)

    @property
    def error_code(self):
        return self._error_code

    @property
    def error_type(self):
        return self._error_type


class DaqReadError(DaqError):
    """Error raised by DAQmx read methods; includes the amount of data that was read."""

    def __init__(self, message, error_code, samps_per_chan_read, task_name=""):
        super().__init__(message, error_code, task_name)
        self._samps_per_chan_read = samps_per_chan_read

    @property
    def samps_per_chan_read(self):
        return self._samps_per_chan_read


class DaqWarning(Warning):
    """Warning raised by any NI-DAQmx method."""

    def __init__(self, message, error_code):
        super().__init__(f"\nWarning {error_code} occurred.\n\n{message}")
        self._error_code = int(error_code)
        try:
            self._error_type = DAQmxWarnings(self._error_code)
        except ValueError:
            self._error_type = DAQmxWarnings.UNKNOWN

    @property
    def error_code(self):
        return self._error_code

    @property
    def error_type(self):
        return self._error_type


class DaqResourceWarning(ResourceWarning):
    """Warning about DAQ resource usage, such as a leaking an NI-DAQmx task."""


warnings.filterwarnings("always", category=DaqWarning)
warnings.filterwarnings("always", category=DaqResourceWarning)
