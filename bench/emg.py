"""Surface EMG: processing cost, the LSL inlet at 2 kHz × 16 channels, and the loop beside EMG.

    .venv/bin/python bench/emg.py [--seconds 20] [--only processing|window|lsl|loop]

1. processing: the whole chain (DC offset, band-pass 20–450 Hz, 50 Hz notch, RMS envelope
   0.125 s / 0.0625 s; core.emg.processing.envelope) on 60 s of 4-channel EMG at 2 kHz,
   per second of EMG; and the RMS envelope alone.
2. window: what the EMG tab computes on its worker at each live refresh (every
   0.2 s): the last 5 s of a 16-channel Trigno stream (1926 Hz) as three muscles' % MVC
   envelopes (ui.views.emg.live_emg_view); and, on its worker, one guided MVC from a 5 s
   push (app.emg.protocol.contraction_mvc).
3. lsl: a sender process pushes 16 channels at 2 kHz in chunks of 20 samples (every
   10 ms, as EMG software does), each sample stamped with local_clock() when it was
   made and carrying its index; this process reads them through device.lsl's inlet
   for `--seconds`. Latency: receive time − sample stamp (p50, p99, max); dropped: indices
   that never arrived.
4. loop: the real 2 ms loop process (simulator, thesis D, recorder), once with this
   process only draining the ring, once with an EMG capture of the 2 kHz × 16 LSL stream
   running here and the robot's state published on LSL (device.lsl.RobotStateOutlet):
   the loop's lateness p99 / max and late ticks, side by side.

Figures only (docs/performance.md, "Surface EMG").
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import tempfile
import time
import uuid
from pathlib import Path

import numpy as np

RATE_HZ = 2000.0
CHANNELS = 16
CHUNK = 20


# ------------------------------------------------------------------ processing
def processing(seconds: float = 60.0) -> tuple[float, float]:
    from core.emg.processing import envelope, rms_envelope
    from core.emg.synthetic import Electrodes, emg_from_excitations

    dt = 0.002
    t = np.arange(0.0, seconds, dt)
    u = 0.2 + 0.1 * np.sin(2 * np.pi * 0.3 * t)[:, None] * np.ones((1, 4))
    _, emg = emg_from_excitations(u, dt, Electrodes(rate_hz=RATE_HZ), seed=0)
    best_full, best_rms = np.inf, np.inf
    for _ in range(5):
        t0 = time.perf_counter()
        envelope(emg, RATE_HZ)
        t1 = time.perf_counter()
        rms_envelope(emg, RATE_HZ)
        t2 = time.perf_counter()
        best_full, best_rms = min(best_full, t1 - t0), min(best_rms, t2 - t1)
    return 1e3 * best_full / seconds, 1e3 * best_rms / seconds


# ------------------------------------------------------------------ the window
def window(repeats: int = 50) -> tuple[float, float, float]:
    """(p50, max) ms of one live refresh in % MVC, and ms of one MVC from a 5 s push."""
    from app.emg.protocol import MvcRecord, SessionMvcs, contraction_mvc
    from core.emg.processing import EmgSettings
    from core.emg.synthetic import TRIGNO_RATE_HZ
    from ui.views.emg import live_emg_view

    rate = TRIGNO_RATE_HZ
    rng = np.random.default_rng(0)
    x = 1e-4 * rng.standard_normal((int(5 * rate), CHANNELS))
    t = np.arange(x.shape[0]) / rate
    settings = EmgSettings()
    session = SessionMvcs("bench", 1)
    contraction_mvc(t, x, rate, "biceps", 0, settings=settings, full_scale_V=0.011,
                    wanted_s=5.0)  # the filters' first call, not the MVC's cost
    t0 = time.perf_counter()
    for muscle, channel in session.channels.items():
        mvc = contraction_mvc(t, x, rate, muscle, channel, settings=settings,
                              full_scale_V=0.011, wanted_s=5.0)
        session.records[muscle] = MvcRecord(mvc, channel, "bench", settings)
    mvc_ms = 1e3 * (time.perf_counter() - t0) / len(session.channels)
    costs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        view = live_emg_view(t, x, rate, session)
        costs.append(time.perf_counter() - t0)
    assert view is not None
    assert view.unit == "% MVC"
    return 1e3 * float(np.median(costs)), 1e3 * max(costs), mvc_ms


# ------------------------------------------------------------------ LSL
def _sender(name: str, seconds: float, ready, done) -> None:
    import pylsl

    info = pylsl.StreamInfo(name, "EMG", CHANNELS, RATE_HZ, pylsl.cf_double64, name)
    described = info.desc().append_child("channels")
    for k in range(CHANNELS):  # as EMG software declares them (device.lsl.inlet)
        channel = described.append_child("channel")
        channel.append_child_value("label", f"EMG{k + 1}")
        channel.append_child_value("unit", "volts")
    outlet = pylsl.StreamOutlet(info)
    ready.set()
    k = 0  # streams from the start, whoever listens, as EMG software does
    start = pylsl.local_clock()
    block = np.zeros((CHUNK, CHANNELS))
    while k < seconds * RATE_HZ:
        due = start + (k + CHUNK) / RATE_HZ
        wait = due - pylsl.local_clock()
        if wait > 0:
            time.sleep(wait)
        now = pylsl.local_clock()
        block[:, 0] = np.arange(k, k + CHUNK)
        block[:, 1:] = 1e-4 * np.sin(block[:, :1] / 7.0)
        # the sample's own time: when it was made, the last of the chunk now
        stamps = (now - (CHUNK - 1 - np.arange(CHUNK)) / RATE_HZ).tolist()
        outlet.push_chunk(block, timestamp=stamps)
        k += CHUNK
    done.put(k)


def lsl_stream(seconds: float) -> dict:
    """Read a sender's stream for `seconds`, from the moment the inlet is open."""
    from device.lsl.inlet import LslEmgInlet
    from device.lsl.library import local_clock

    name = f"bench-emg-{uuid.uuid4().hex[:8]}"
    ctx = mp.get_context("spawn")
    ready, done = ctx.Event(), ctx.Queue()
    sender = ctx.Process(target=_sender, args=(name, seconds + 10.0, ready, done), daemon=True)
    sender.start()
    ready.wait(30)
    inlet = LslEmgInlet(name, channels=CHANNELS, rate_hz=RATE_HZ, timeout_s=10.0).open(10.0)
    inlet.read(0.5)  # what queued while the inlet was opening
    latencies, indices = [], []
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        stamps, samples = inlet.read(0.05)
        now = local_clock()
        if stamps.size:
            latencies.append(now - stamps)
            indices.append(samples[:, 0])
    inlet.close()
    sender.terminate()
    sender.join(10)
    lat = np.concatenate(latencies)
    got = np.concatenate(indices)
    expected = int(got.max() - got.min()) + 1
    return {"sent": expected, "received": np.unique(got).size,
            "dropped": expected - np.unique(got).size,
            "p50_ms": 1e3 * np.percentile(lat, 50), "p99_ms": 1e3 * np.percentile(lat, 99),
            "max_ms": 1e3 * lat.max()}


# ------------------------------------------------------------------ the loop beside EMG
def loop(seconds: float, with_emg: bool, folder: Path) -> dict:
    from app.trials.reader import read_trial
    from core.trial import THESIS_SUBJECT
    from device.emg.capture import EmgCapture
    from device.loop.client import DeviceClient
    from device.loop.messages import BackendConfig, ClockStarted
    from device.loop.pipeline import PERIOD_S
    from device.lsl.inlet import LslEmgInlet
    from device.lsl.outlet import RobotStateOutlet
    from device.recording.messages import RecorderNotice
    from device.recording.trialfile import SubjectInfo

    params = THESIS_SUBJECT.replace(repetitions=max(1, round(seconds / 4.0)))
    path = folder / f"loop-{'emg' if with_emg else 'alone'}-{uuid.uuid4().hex[:6]}.h5"
    sender = capture = outlet = None
    if with_emg:
        name = f"bench-emg-{uuid.uuid4().hex[:8]}"
        ctx = mp.get_context("spawn")
        ready, done = ctx.Event(), ctx.Queue()
        sender = ctx.Process(target=_sender, args=(name, seconds + 60, ready, done),
                             daemon=True)
        sender.start()
        ready.wait(30)
        capture = EmgCapture(LslEmgInlet(name, channels=CHANNELS, timeout_s=10.0).open(10.0))
        capture.start()
        outlet = RobotStateOutlet(500.0, source_id=f"bench-{name}")
    with DeviceClient() as client:
        assert client.build(params, BackendConfig()).ok
        assert client.connect().ok
        time.sleep(0.5)
        assert client.start_trial(str(path), SubjectInfo.from_parameters("PBENCH0", params)).ok
        seen = []
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            # as the window's worker does: the records, then the messages that say their clock
            records, first_seq = client.live_batch()
            events = client.events(0.01)
            seen += events
            if outlet is not None:
                for event in events:
                    if isinstance(event, ClockStarted):
                        outlet.clock_started(event.first_seq, event.origin_monotonic_s)
                outlet.push_records(records, first_seq)
        if not any(isinstance(e, RecorderNotice) and e.kind == "closed" for e in seen):
            client.wait_for(lambda e: isinstance(e, RecorderNotice) and e.kind == "closed", 60)
    captured = capture.stop() if capture is not None else None
    if sender is not None:
        sender.terminate()
        sender.join(5)
    data = read_trial(path)
    running = data.channels["phase"] > 0
    late = data.channels["lateness"][running].astype(float)
    return {"ticks": int(running.sum()), "p50_ms": 1e3 * np.percentile(late, 50),
            "p99_ms": 1e3 * np.percentile(late, 99), "max_ms": 1e3 * late.max(),
            "late_pct": 100 * np.mean(late > PERIOD_S),
            "emg_samples": 0 if captured is None else captured.samples.shape[0],
            "published": 0 if outlet is None else outlet.pushed}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=20.0)
    parser.add_argument("--only", choices=("processing", "window", "lsl", "loop"))
    parser.add_argument("--repeats", type=int, default=1,
                        help="loop runs of each kind, alternated (the machine's load varies)")
    args = parser.parse_args()
    from device.lsl.library import use_loopback

    use_loopback(Path(tempfile.mkdtemp(prefix="bench-lsl-")))  # nothing beyond this machine
    if args.only in (None, "processing"):
        full, rms = processing()
        print(f"processing, per second of 4-channel 2 kHz EMG: whole chain {full:.2f} ms "
              f"(band-pass, notch, RMS envelope), RMS envelope alone {rms:.3f} ms")
    if args.only in (None, "window"):
        p50, worst, mvc_ms = window()
        print(f"EMG tab, one live refresh (5 s × 16 channels at 1926 Hz, 3 muscles in % MVC): "
              f"p50 {p50:.1f} ms, max {worst:.1f} ms, every 200 ms, on the tab's worker; one MVC "
              f"from a 5 s push {mvc_ms:.1f} ms")
    if args.only in (None, "lsl"):
        r = lsl_stream(args.seconds)
        print(f"LSL inlet, {CHANNELS} channels at {RATE_HZ:g} Hz for {args.seconds:g} s: "
              f"{r['received']} of {r['sent']} samples, {r['dropped']} dropped; latency "
              f"p50 {r['p50_ms']:.2f} ms, p99 {r['p99_ms']:.2f} ms, max {r['max_ms']:.2f} ms")
    if args.only in (None, "loop"):
        with tempfile.TemporaryDirectory() as folder:
            runs = []
            for _ in range(args.repeats):
                runs += [("alone", loop(args.seconds, False, Path(folder))),
                         ("with EMG", loop(args.seconds, True, Path(folder)))]
        print(f"the loop over {args.seconds:g} s trials (simulator, compiled tick):")
        print(f"{'run':<10}{'ticks':>7}{'p50 ms':>9}{'p99 ms':>9}{'max ms':>10}{'late %':>8}"
              f"{'EMG samples':>13}{'published':>11}")
        for label, r in runs:
            print(f"{label:<10}{r['ticks']:7d}{r['p50_ms']:9.3f}{r['p99_ms']:9.3f}"
                  f"{r['max_ms']:10.3f}{r['late_pct']:8.3f}{r['emg_samples']:13d}"
                  f"{r['published']:11d}")


if __name__ == "__main__":
    main()
