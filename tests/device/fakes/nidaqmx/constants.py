"""The subset of `nidaqmx.constants` the force sensor uses, with the real values (1.7.0)."""

from enum import Enum

READ_ALL_AVAILABLE = -1
WAIT_INFINITELY = -1.0


class AcquisitionType(Enum):
    FINITE = 10178
    CONTINUOUS = 10123
    HW_TIMED_SINGLE_POINT = 12522


class Edge(Enum):
    RISING = 10280
    FALLING = 10171


class FillMode(Enum):
    GROUP_BY_CHANNEL = 0
    GROUP_BY_SCAN_NUMBER = 1


class OverwriteMode(Enum):
    OVERWRITE_UNREAD_SAMPLES = 10252
    DO_NOT_OVERWRITE_UNREAD_SAMPLES = 10159


class ReadRelativeTo(Enum):
    FIRST_SAMPLE = 10424
    CURRENT_READ_POSITION = 10425
    REFERENCE_TRIGGER = 10426
    FIRST_PRETRIGGER_SAMPLE = 10427
    MOST_RECENT_SAMPLE = 10428


class TerminalConfiguration(Enum):
    RSE = 10083
    NRSE = 10078
    DIFF = 10106
    PSEUDO_DIFF = 12529
    DEFAULT = -1


class VoltageUnits(Enum):
    VOLTS = 10348
    FROM_CUSTOM_SCALE = 10065
    FROM_TEDS = 12516
