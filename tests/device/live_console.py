"""A console as `rehab gui` runs one, without its window: the device link, one live trial on
the simulator, every event it hears printed as a JSON line. Run by the fault-injection
tests and bench/fault_injection.py in a process group of its own, so that a signal can be
sent to the group, a process killed or stopped, or the disk filled under it.

    python tests/device/live_console.py TRIAL.h5

stdin takes commands, one a line: `stop` (the therapist's Stop), `quit` (close the
console as its window's close button does). A stop signal (SIGINT, SIGTERM, SIGHUP) closes
it as the window does: the loop is told the signal, the trial stops as a fault naming it.

Fault injection at the trial file's writes, for machines where a disk cannot be filled
for real (no tmpfs mount) and for errors no disk gives on demand: with the environment
variable REHAB_INJECT_AT naming a file, once that file exists every process of this
console meets, at the recorder's next write, the fault REHAB_INJECT names: `enospc`
(the disk is full: the reserve's fallocate fails, no space is free) or `eio` (every
write of the trial file fails with an I/O error). This script's top level runs in every
process multiprocessing spawns from it, which is how the injection reaches the recorder.
"""

from __future__ import annotations

import errno
import json
import os
import sys
import threading
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

TRIGGER = os.environ.get("REHAB_INJECT_AT", "")
INJECT = os.environ.get("REHAB_INJECT", "")


def _install_injection() -> None:
    import device.recording.trialfile.reserve as reserve
    import device.recording.trialfile.writer as writer

    def injected() -> bool:
        return os.path.exists(TRIGGER)

    if INJECT == "enospc":
        fallocate, free_bytes = reserve.fallocate, writer._free_bytes

        def full_fallocate(fd, mode, offset, length):
            if injected() and not mode & reserve.FALLOC_FL_PUNCH_HOLE:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return fallocate(fd, mode, offset, length)

        reserve.fallocate = full_fallocate
        writer._free_bytes = lambda folder: 0 if injected() else free_bytes(folder)
    elif INJECT == "eio":
        flush = writer.TrialFileWriter._flush

        def failing_flush(self):
            if injected():
                raise OSError(errno.EIO, os.strerror(errno.EIO))
            return flush(self)

        writer.TrialFileWriter._flush = failing_flush


if TRIGGER:
    _install_injection()


def _say(event: str, **values) -> None:
    print(json.dumps({"event": event, "at": time.monotonic(), **values}, default=str),
          flush=True)


def _report(event) -> None:
    from dataclasses import asdict, is_dataclass

    if is_dataclass(event):
        _say(type(event).__name__, **asdict(event))


def main() -> int:
    from core.trial import THESIS_SUBJECT
    from device.loop.client import DeviceClient, LoopLost
    from device.recording.messages import RecorderNotice
    from device.recording.trialfile import SubjectInfo
    from device.stopsignals import StopSignal
    from tests.patience import patient_loop_client

    patient_loop_client()  # a test waits for the loop's samples, not for a prompt host
    stop = StopSignal().install()
    path = sys.argv[1]
    params = THESIS_SUBJECT.replace(repetitions=20)
    client = DeviceClient()
    client.start()
    commands: list[str] = []
    threading.Thread(target=lambda: commands.extend(line.strip() for line in sys.stdin),
                     daemon=True).start()
    assert client.build(params).ok
    assert client.connect().ok
    client.wait_for_samples(10)
    reply = client.start_trial(path, SubjectInfo.from_parameters("PFAULT1", params))
    assert reply.ok, reply.message
    _say("started", console=os.getpid(), loop=client.loop_pid, recorder=client.recorder_pid,
         ring=client.ring.name, path=path)
    closed_at = None
    while not stop.name:
        for event in client.events(0.02):
            _report(event)
            if isinstance(event, RecorderNotice) and event.kind in ("closed", "lost"):
                closed_at = time.monotonic()  # the file's end, whichever it was
            if isinstance(event, LoopLost) and closed_at is None:
                closed_at = time.monotonic() + 5.0  # the recorder's close may follow
        while commands:
            command = commands.pop(0)
            if command == "stop":
                _report(client.stop())
            elif command == "quit":
                stop.set("quit")
        if closed_at is not None and time.monotonic() > closed_at + 0.5:
            break
    for event in client.close(signal="" if stop.name in ("", "quit") else stop.name):
        _report(event)
    _say("closed", signal=stop.name)
    return 0


if __name__ == "__main__":
    sys.exit(main())
