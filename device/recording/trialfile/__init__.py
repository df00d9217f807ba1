"""The trial file: one HDF5 file per trial, written live by the recorder (docs/data-format.md).

By job: `layout` (the format's names, tables and rules), `writer` (writing a trial live),
`header` (what a new file holds before its first sample), `whole` (a whole trial at once),
`reserve` (the disk space a file holds), `summary` (what close computes), `update` (adding
to a closed trial: metrics, estimates, EMG, pose).
Reading is app.trials.reader's.
"""

from device.recording.trialfile.layout import (
    ALREADY_OPEN,
    CHUNK_ROWS,
    EVENT_DTYPE,
    EVENT_KIND_BYTES,
    EVENT_MESSAGE_BYTES,
    EVENT_VALUES_BYTES,
    FORMAT_NAME,
    FORMAT_VERSION,
    LIBVER,
    MIN_FREE_BYTES,
    STATUS_RECORDING,
    STATUSES,
    UPDATE_RETRY_S,
    UPDATE_WAIT_S,
    SubjectInfo,
    software_version,
    utc_now_iso,
)
from device.recording.trialfile.update import (
    add_assistance,
    open_for_update,
    refuse_while_recording,
    write_metrics,
)
from device.recording.trialfile.whole import write_trial
from device.recording.trialfile.writer import TrialFileWriter

__all__ = [
    "ALREADY_OPEN", "CHUNK_ROWS", "EVENT_DTYPE", "EVENT_KIND_BYTES", "EVENT_MESSAGE_BYTES",
    "EVENT_VALUES_BYTES", "FORMAT_NAME", "FORMAT_VERSION", "LIBVER", "MIN_FREE_BYTES",
    "STATUSES", "STATUS_RECORDING", "UPDATE_RETRY_S", "UPDATE_WAIT_S", "SubjectInfo",
    "TrialFileWriter", "add_assistance", "open_for_update", "refuse_while_recording",
    "software_version", "utc_now_iso", "write_metrics", "write_trial",
]
