"""Fake of `nidaqmx.stream_readers.AnalogMultiChannelReader` (1.7.0).

As in the real reader: the array's shape is checked first (a wrong shape raises
DaqError with code -1, DAQmxErrors.UNKNOWN); then the array goes to C through a
`numpy.ctypeslib.ndpointer(float64, flags=("C", "W"))` argument, so a wrong
dtype, a non-contiguous or a read-only array raises `ctypes.ArgumentError`.
Rows are channels in the order they were added (GROUP_BY_CHANNEL).
"""

from __future__ import annotations

import ctypes

import numpy as np
from numpy.ctypeslib import ndpointer

from nidaqmx.constants import READ_ALL_AVAILABLE
from nidaqmx.error_codes import DAQmxErrors
from nidaqmx.errors import DaqError

_F64_ARRAY = ndpointer(dtype=np.float64, flags=("C", "W"))


def _to_c(data) -> None:
    try:
        _F64_ARRAY.from_param(data)
    except TypeError as exc:
        raise ctypes.ArgumentError(f"argument 5: TypeError: {exc}") from None


class AnalogMultiChannelReader:
    def __init__(self, task_in_stream) -> None:
        self._in_stream = task_in_stream
        self._task = task_in_stream._task
        self._verify_array_shape = True

    @property
    def verify_array_shape(self) -> bool:
        return self._verify_array_shape

    @verify_array_shape.setter
    def verify_array_shape(self, val) -> None:
        self._verify_array_shape = val

    def _verify(self, data, shape) -> None:
        if self._verify_array_shape and data.shape != shape:
            raise DaqError(
                "Read cannot be performed because the NumPy array passed into this function is "
                "not shaped correctly. You must pass in a NumPy array of the correct shape based "
                "on the number of channels in task and the number of samples per channel "
                f"requested.\n\nShape of NumPy Array provided: {data.shape}\n"
                f"Shape of NumPy Array required: {shape}",
                DAQmxErrors.UNKNOWN, task_name=self._task.name,
            )

    def read_one_sample(self, data, timeout=10) -> None:
        self._verify(data, (self._in_stream.num_chans,))
        _to_c(data)
        self._task._read_into(data.reshape(-1, 1), 1, timeout)

    def read_many_sample(
        self, data, number_of_samples_per_channel=READ_ALL_AVAILABLE, timeout=10.0
    ) -> int:
        count = self._task._calculate_num_samps_per_chan(number_of_samples_per_channel)
        self._verify(data, (self._in_stream.num_chans, count))
        _to_c(data)
        return self._task._read_into(data, count, timeout)
