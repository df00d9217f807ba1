"""Why a running trial was stopped, in the therapist's words, with its cause in the fault's
detail: the recorder gone or stalled, the disk full or failing, a stop signal (a part of
device.loop.process.DeviceLoop)."""

from __future__ import annotations

from device.recording.messages import (
    DISK_SHORT,
    STOPPED_BY_SIGNAL,
    WRITE_FAILED,
)
from device.stopsignals import signal_name

RECORDER_CHECK_TICKS = 25
"""How often (ticks: 50 ms) a running trial checks that the recorder is still there."""
RECORDER_GONE = ("The recorder stopped, so nothing more of this trial could be saved; the "
                 "motors were stopped. The trial's file keeps what reached it, and the "
                 "trial is marked incomplete. Restart the console before the next trial")
RECORDER_STALLED = ("The recorder stopped responding, so the motors were stopped; the trial's "
                    "file keeps what reached it and the trial is marked incomplete. Restart "
                    "the console before the next trial")

RECORDING_CAUSES = {
    WRITE_FAILED: ("write error", "The trial file could not be written (a disk error), so "
                   "the motors were stopped. The file keeps what was saved before the error "
                   "and the trial is marked incomplete. Check the disk before the next trial"),
    DISK_SHORT: ("disk full", "The disk holding the trial files is full, so the motors were "
                 "stopped. Every sample so far is saved in the trial's file, which is marked "
                 "incomplete. Free space on that disk before the next trial"),
}
"""What the recorder's flag says (device.recording.messages), as the fault's cause and
message."""


class StopCauses:
    """The causes of a lost recording or a stop signal (a part of DeviceLoop)."""

    def _recording_cause(self, detail: dict) -> str:
        """Why the recording was lost, in the therapist's words, with its cause in the
        fault's detail; '' when it is the ring overflowing (the supervisor's own words)."""
        if self.recorder_gone:
            # the right cause: not the disk, the process that writes to it
            detail["cause"] = "recorder process stopped"
            return RECORDER_GONE
        if self.recorder_stalled:
            detail["cause"] = "recorder stopped responding"
            detail["silent_ticks"] = self.recorder_pulse.silent
            return RECORDER_STALLED
        flag = int(self.recording_failed.value)
        if flag > STOPPED_BY_SIGNAL:
            name = signal_name(flag - STOPPED_BY_SIGNAL)
            detail["cause"] = f"signal {name}"
            return (f"The recorder was told to stop ({name}), so the motors were stopped and "
                    "the trial saved as incomplete. Restart the console before the next trial")
        cause = RECORDING_CAUSES.get(flag)
        if cause is None:
            return ""
        detail["cause"], message = cause
        return message

    def _recorder_stopped(self) -> bool:
        """Whether the recorder's beat has been silent too long (device.loop.
        recorder_watch): counted at every tick of a running trial."""
        if not self.recorder_stalled and self.recorder_pulse.stalled():
            self.recorder_stalled = True
        return self.recorder_stalled

    def _signal_cause(self, detail: dict) -> str:
        """A stop signal stopped the trial: the fault's words and cause name it."""
        detail["cause"] = f"signal {self.stop_signal.name}"
        return (f"The console was told to stop ({self.stop_signal.words}), so the motors "
                "were stopped at once and the trial saved as faulted")
