"""The subset of `nidaqmx.error_codes` the fakes raise, with the real values (1.7.0)."""

from enum import IntEnum


class DAQmxErrors(IntEnum):
    DEV_CANNOT_BE_ACCESSED = -201003
    SAMPLES_NOT_YET_AVAILABLE = -200284
    SAMPLES_NO_LONGER_AVAILABLE = -200279
    INVALID_DEVICE_ID = -200220
    PHYSICAL_CHAN_DOES_NOT_EXIST = -200170
    INVALID_TASK = -200088
    INVALID_ATTRIBUTE_VALUE = -200077
    RESOURCE_ALREADY_RESERVED = -200022
    ADC_OVERRUN = -200019
    INPUT_FIFO_OVERFLOW = -200010
    UNKNOWN = -1


class DAQmxWarnings(IntEnum):
    UNKNOWN = -1
    ADC_OVERLOADED = 200005
