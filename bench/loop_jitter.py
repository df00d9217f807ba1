"""Timing of the 2 ms loop, alone and beside a live pyqtgraph window.

    .venv/bin/python bench/loop_jitter.py [--seconds 60] [--only alone|window]
                                          [--engine compiled|python] [--timing real]
    xvfb-run -a .venv/bin/python bench/loop_jitter.py        # a real (virtual) X display

Runs the real loop process (simulator backend, healthy virtual patient, thesis D, SMC,
assistance on, supervisor, recorder writing the trial file) for `--seconds`:

1. alone: this process only drains the ring (as the recorder's sibling would);
2. window: this process shows a pyqtgraph window with 8 curves of 10 s at the loop rate
   (5,000 points each), fed from the ring and repainted by a 16 ms QTimer with setData.

Prints lateness p50 / p99 / p99.9 / max, the share of ticks later than one period, how many
ticks were later than the hardware's 10 ms watchdog, the loop's compute time p99 (sensor
read to torque written), the window's repaint rate, and what recording costs the loop (the
ring push per tick, measured here on the same record). By default the simulator is
stepped by the nominal period and lateness faults nothing (device.backend); `--timing
real` runs it on the wall clock with the hardware's watchdog, as the real robot would be.
Figures only. Goals (docs/performance.md): beside the window, lateness p99 ≤ 0.25 ms, max ≤ 2 ms,
≤ 0.1 % late, compute p99 ≤ 50 µs, recording ≤ 1 % of the tick.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import tempfile
import time
from pathlib import Path

import numpy as np

from app.trials.reader import read_trial
from core.trial import THESIS_SUBJECT
from device.loop.client import DeviceClient
from device.loop.messages import BackendConfig
from device.loop.pipeline import PERIOD_S, TickPipeline, TrialPlan
from device.loop.process import LoopConfig
from device.recording.messages import RecorderNotice
from device.recording.record import RECORD_DTYPE
from device.recording.ring import RecordRing
from device.recording.trialfile import SubjectInfo
from device.safety.limits import SafetyLimits
from device.sim.simulator import SimulatorBackend

CURVES = 8
WINDOW_S = 10.0


def run_trial(seconds: float, folder: Path, label: str, window: bool,
              cpu: int | None = None, compiled: bool = True, timing: str | None = None) -> dict:
    reps = max(1, round(seconds / THESIS_SUBJECT.duration_s))
    params = THESIS_SUBJECT.replace(repetitions=reps)
    path = folder / f"{label}.h5"
    fps = float("nan")
    config = LoopConfig(compiled=compiled)
    if cpu is not None:
        config = dataclasses.replace(config, cpu=None if cpu < 0 else cpu)
    with DeviceClient(loop_config=config) as client:
        assert client.build(params, BackendConfig(timing=timing)).ok
        assert client.connect().ok
        time.sleep(0.5)
        assert client.start_trial(str(path), SubjectInfo.from_parameters("PBENCH0", params)).ok
        seen: list = []
        if window:
            fps = _window(client, seconds, seen)
        else:
            _drain(client, seconds, seen)
        if not any(isinstance(e, RecorderNotice) and e.kind == "closed" for e in seen):
            seen += client.wait_for(
                lambda e: isinstance(e, RecorderNotice) and e.kind == "closed", 30)
        notices = [e for e in seen if type(e).__name__ == "Notice"]
    data = read_trial(path)
    exercise = data.channels["phase"] > 0
    lateness = data.channels["lateness"][exercise].astype(float)
    compute = data.channels["compute_time"][exercise].astype(float)
    return {
        "label": label, "ticks": int(exercise.sum()), "status": data.status,
        "p50_ms": 1e3 * np.percentile(lateness, 50),
        "p99_ms": 1e3 * np.percentile(lateness, 99),
        "p999_ms": 1e3 * np.percentile(lateness, 99.9),
        "max_ms": 1e3 * lateness.max(),
        "late_pct": 100.0 * np.mean(lateness > PERIOD_S),
        "over_watchdog": int(np.count_nonzero(lateness > SafetyLimits().late_tick_s)),
        "compute_p99_us": 1e6 * np.percentile(compute, 99),
        "fps": fps, "notices": [n.message for n in notices],
    }


def _drain(client: DeviceClient, seconds: float, seen: list) -> None:
    end = time.monotonic() + seconds
    while time.monotonic() < end:
        client.live_records()
        seen += client.events(0.05)


def _window(client: DeviceClient, seconds: float, seen: list) -> float:
    if not os.environ.get("DISPLAY"):
        os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    import pyqtgraph as pg
    from PySide6.QtCore import QTimer
    from PySide6.QtWidgets import QApplication

    app = QApplication.instance() or QApplication([])
    n = round(WINDOW_S / PERIOD_S)
    buffer = np.zeros((n, CURVES))
    t = np.arange(n) * PERIOD_S
    win = pg.GraphicsLayoutWidget()
    win.resize(1280, 800)
    curves = []
    for i in range(CURVES):
        plot = win.addPlot(row=i, col=0)
        curves.append(plot.plot(t, buffer[:, i], pen=pg.mkPen(width=1)))
    win.show()
    fields = ("position", "force", "subject_angle_isb", "subject_torque")
    frames = [0]

    def repaint() -> None:
        records = client.live_records()
        seen.extend(client.events())
        m = len(records)
        if m:
            new = np.column_stack([records[f] for f in fields])
            m = min(m, n)
            buffer[:-m] = buffer[m:]
            buffer[-m:] = new[-m:]
        for i, curve in enumerate(curves):
            curve.setData(t, buffer[:, i])
        frames[0] += 1

    timer = QTimer()
    timer.timeout.connect(repaint)
    timer.start(16)
    started = time.monotonic()
    while time.monotonic() - started < seconds:
        app.processEvents()
        time.sleep(0.001)
    timer.stop()
    elapsed = time.monotonic() - started
    win.close()
    return frames[0] / elapsed


def recording_cost_us(samples: int = 20000) -> tuple[float, float]:
    """The loop's recording work per tick: building the record and pushing it."""
    params = THESIS_SUBJECT.replace(repetitions=1)
    plan = TrialPlan.build(params)
    sim = SimulatorBackend.from_trial(params)
    sim.open()
    pipeline = TickPipeline(plan)
    reading = sim.read(0.0)
    pipeline.begin(reading.q1_rad, reading.q2_rad)
    pipeline.control(0, reading)
    ring = RecordRing.create(4096, RECORD_DTYPE, recorded=False)
    try:
        build, push = [], []
        clock = time.perf_counter_ns
        for k in range(samples):
            t0 = clock()
            record = pipeline.record(k, reading, 0.0, 0.0, 0.0, (0.0, 0.0), 3, 0)
            t1 = clock()
            ring.push(record)
            t2 = clock()
            build.append(t1 - t0)
            push.append(t2 - t1)
    finally:
        ring.close()
        ring.unlink()
        sim.close()
    return float(np.percentile(build, 99)) / 1e3, float(np.percentile(push, 99)) / 1e3


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=60.0)
    parser.add_argument("--only", choices=("alone", "window"))
    parser.add_argument("--engine", choices=("compiled", "python"), default="compiled",
                        help="the loop's running tick: compiled (the default) or Python")
    parser.add_argument("--cpu", type=int, help="pin the loop to this CPU; -1: no pinning "
                                                "(default: the last CPU, as the console does)")
    parser.add_argument("--timing", choices=("simulated", "real"), default="simulated",
                        help="real: the simulator on the wall clock with the hardware's "
                             "late-tick watchdog")
    args = parser.parse_args()
    runs = []
    with tempfile.TemporaryDirectory() as folder:
        for label in ("alone", "window"):
            if args.only in (None, label):
                runs.append(run_trial(args.seconds, Path(folder), label, label == "window",
                                      args.cpu, args.engine == "compiled",
                                      None if args.timing == "simulated" else args.timing))
    print(f"Loop timing over {args.seconds:g} s trials, {args.engine} tick, {args.timing} "
          f"timing (display: "
          f"{os.environ.get('QT_QPA_PLATFORM') or os.environ.get('DISPLAY', '?')})")
    print(f"{'run':<8}{'ticks':>7}{'p50 ms':>8}{'p99 ms':>8}{'p99.9 ms':>10}{'max ms':>8}"
          f"{'late %':>8}{'>10 ms':>7}{'compute p99 µs':>16}{'window fps':>12}  status")
    for r in runs:
        print(f"{r['label']:<8}{r['ticks']:7d}{r['p50_ms']:8.3f}{r['p99_ms']:8.3f}"
              f"{r['p999_ms']:10.3f}{r['max_ms']:8.3f}{r['late_pct']:8.3f}{r['over_watchdog']:7d}"
              f"{r['compute_p99_us']:16.1f}{r['fps']:12.1f}  {r['status']}")
        for notice in r["notices"]:
            print(f"  notice: {notice}")
    build_us, push_us = recording_cost_us()
    print(f"recording per tick: record {build_us:.1f} µs p99 + ring push {push_us:.1f} µs p99 "
          f"= {100 * (build_us + push_us) / (PERIOD_S * 1e6):.2f} % of the 2 ms tick")


if __name__ == "__main__":
    main()
