"""Fake of the `nidaqmx` 1.7.0 package (PyPI) for tests without NI-DAQmx.

Module layout, names, signatures, enum values and error classes follow the real
package; the driver is replaced by simulated devices in `nidaqmx._fake`.
"""

from nidaqmx.errors import DaqError, DaqReadError, DaqResourceWarning, DaqWarning
from nidaqmx.task import Task

__version__ = "1.7.0"

__all__ = ["DaqError", "DaqReadError", "DaqResourceWarning", "DaqWarning", "Task"]
