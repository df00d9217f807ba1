"""The robot's LSL stream across Connect/Disconnect cycles and trial starts, as LabRecorder
receives it: for each connection, the gap to the previous one's last stamp (never
negative), and for each trial the ticks of its file found in the stream at their stamps.

    .venv/bin/python bench/lsl_outlet.py [--cycles 5] [--starts 10]

The real loop on the simulator; records and messages are read as the window's device
worker reads them (ui.device_bridge: the records, then the messages), into the
console's RobotStateOutlet; an inlet in this process records the stream. LSL is confined
to this machine (device.lsl.library.use_loopback).
"""

from __future__ import annotations

import argparse
import tempfile
import threading
import time
import uuid
from pathlib import Path

import numpy as np


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=5)
    parser.add_argument("--starts", type=int, default=10)
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="bench-lsl-outlet-"))
    from device.lsl.library import use_loopback

    use_loopback(folder)
    import pylsl

    from app.trials.reader import read_trial
    from core.trial import THESIS_SUBJECT
    from device.loop.client import DeviceClient
    from device.loop.messages import BackendConfig, ClockStarted, TrialMarker
    from device.lsl.outlet import RobotStateOutlet
    from device.recording.messages import RecorderNotice
    from device.recording.trialfile import SubjectInfo

    source = f"bench-{uuid.uuid4().hex[:8]}"
    outlet = RobotStateOutlet(500.0, source_id=source)
    inlet = pylsl.StreamInlet(pylsl.resolve_byprop("source_id", source, 1, 10.0)[0],
                              max_buflen=600, recover=False)
    inlet.open_stream(10.0)
    stamps: list[float] = []
    stop = threading.Event()

    def record():
        while not stop.is_set():
            try:
                _, t = inlet.pull_chunk(timeout=0.2, max_samples=10000)
            except pylsl.util.LostError:
                return
            stamps.extend(t)

    recorder = threading.Thread(target=record, daemon=True)
    recorder.start()
    params = THESIS_SUBJECT.replace(repetitions=1)
    subject = SubjectInfo.from_parameters("PBENCH0", params)
    files, connects = [], []

    def drain(client):
        records, first = client.live_batch()
        events = client.events(0.005)
        for event in events:
            if isinstance(event, ClockStarted):
                outlet.clock_started(event.first_seq, event.origin_monotonic_s)
                connects.append(event.origin_monotonic_s)
            elif isinstance(event, TrialMarker):
                outlet.mark(event)
        outlet.push_records(records, first)
        return events

    with DeviceClient() as client:
        assert client.build(params, BackendConfig(seed=1)).ok
        for cycle in range(args.cycles):
            assert client.connect().ok
            for _ in range(20):
                drain(client)
            for start in range(args.starts):
                path = folder / f"c{cycle}s{start}.h5"
                reply = client.start_trial(str(path), subject)
                while not reply.ok and "still being closed" in reply.message:
                    drain(client)  # the last trial's samples still going to its file
                    reply = client.start_trial(str(path), subject)
                assert reply.ok, reply.message
                end = time.monotonic() + 0.01 * (start % 4)
                while time.monotonic() < end:
                    drain(client)
                assert client.stop().ok
                closed = False
                while not closed:
                    closed = any(isinstance(e, RecorderNotice) and e.kind == "closed"
                                 for e in drain(client))
                files.append(path)
            for _ in range(20):
                drain(client)
            assert client.disconnect().ok
            drain(client)
    time.sleep(1.0)
    outlet.close()
    stop.set()
    recorder.join(10.0)
    t = np.array(stamps)
    steps = np.diff(t)
    print(f"{len(t)} samples over {args.cycles} connections and {len(files)} trials; "
          f"smallest step {1e3 * steps.min():.3f} ms (negative: the stream went back)")
    for k, origin in enumerate(connects[1:], start=1):
        before = t[t < origin]
        after = t[t >= origin]
        print(f"connection {k + 1}: gap from the last stamp before it "
              f"{after[0] - before[-1]:.3f} s")
    at = {round(x, 9) for x in t}
    missing = []
    for path in files:
        data = read_trial(path)
        origin = data.summary["wall_time_origin_monotonic_s"]
        want = origin + data.channels["wall_time"]
        missing.append(sum(round(x, 9) not in at for x in want))
    print(f"trial ticks not in the stream: {sum(missing)} of "
          f"{sum(read_trial(p).n_samples for p in files)} (per trial: max {max(missing)})")


if __name__ == "__main__":
    main()
