"""The recorder's pulse as the loop sees it: a counter the recorder raises every
RECORDER_BEAT_S (device.recording.messages), which the loop reads at every tick of a
running trial (issue 28, item 6).

Why: a stopped recorder (SIGSTOP, a debugger, a frozen disk driver holding it) was
noticed only when the 16 s ring overflowed; the last 3.5 s were then lost. A dead one
closes its pipe and is seen at once; a stopped one does not. Counted in the loop's own
ticks, not in wall-clock seconds: a machine that stalls every process for a moment
(a VM paused by its host) delays the loop's ticks as much as the recorder's beat, so it
is never taken for a stopped recorder, and a test proves the limit with no clock.
"""

from __future__ import annotations

RECORDER_SILENT_TICKS = 1500
"""Ticks of a running trial (3 s at 2 ms) without a beat after which the recorder counts as
stopped; with the beat's own 0.05 s, a stop is noticed within 3.05 s of it. Nothing is lost
meanwhile: the ring holds 16 s, and the console saves from it what a stopped recorder did
not write. Long enough that a recorder merely kept from the CPU is not taken for a stopped
one: at 0.4 s a whole check on the loaded 2-core CI machine stopped a live trial with
"the recorder stopped responding" (the loop runs at real-time priority, the recorder does
not), and its beat thread also waits for the GIL while h5py writes."""


class RecorderPulse:
    """`stalled()` at every tick of a running trial: True once `limit_ticks` ticks in a row
    saw the recorder's counter unchanged. `reset()` at a trial's start."""

    def __init__(self, beat, limit_ticks: int = RECORDER_SILENT_TICKS) -> None:
        self.beat = beat
        self.limit_ticks = int(limit_ticks)
        self.seen = None if beat is None else beat.value
        self.silent = 0

    def reset(self) -> None:
        self.seen = None if self.beat is None else self.beat.value
        self.silent = 0

    def stalled(self) -> bool:
        if self.beat is None:
            return False
        value = self.beat.value
        if value != self.seen:
            self.seen = value
            self.silent = 0
            return False
        self.silent += 1
        return self.silent >= self.limit_ticks
