"""Faults injected into live trials on the simulator, with the real processes (issue 28):
each process killed (SIGKILL) or stopped (SIGSTOP), the stop signals sent to the console's
process group, the disk filled to 100 % and a write failing, each at a random tick of the
trial. `run_fault` runs one and says what the trial file then holds: whether it reads,
the cause it records, how many of the ticks the loop pushed it lacks, and when the
fault was seen. tests/device/test_live_faults.py asserts on them; bench/fault_injection.py
prints them as a table.

The console is tests/device/live_console.py in a process group of its own; this process
attaches to its ring as a reader, to know which ticks the loop pushed and when a fault
latched, counted in the loop's ticks.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from app.errors import AppError
from app.trials.reader import read_trial
from device.loop.states import State
from device.recording.ring import RecordRing
from device.safety.faults import Fault
from tests.patience import HANG_S

ROOT = Path(__file__).resolve().parents[2]
CONSOLE = Path(__file__).with_name("live_console.py")
PERIOD_S = 0.002
LOOP_HELD_S = 0.1
"""How long "loop SIGSTOP" holds the loop stopped after the recorder drained the ring (at
least: the sleep may last longer, never shorter)."""
FAULTS = ("loop SIGKILL", "loop SIGSTOP", "recorder SIGKILL", "recorder SIGSTOP",
          "console SIGKILL", "console SIGSTOP", "group SIGINT", "group SIGTERM",
          "group SIGHUP", "disk full", "write EIO")
WAIT_S = HANG_S
"""The longest any step waits for the processes (a bound on a stuck run, never a figure):
the live console itself waits a minute for the loop's first samples (tests/patience.py)."""


@dataclass
class Outcome:
    fault: str
    how: str
    """How the fault was made: 'tmpfs' (a real full disk), 'injected' (at the write call)."""
    status: str = ""
    readable: bool = False
    problem: str = ""
    causes: list[str] = field(default_factory=list)
    """What the file records as the cause: its fault and recording events' causes and
    messages (with the console's, where the file cannot hold it)."""
    injected_tick: int = -1
    fault_tick: int = -1
    """The first tick the file (or the ring) shows a fault code; -1 when none latched."""
    last_pushed_tick: int = -1
    ticks: np.ndarray = field(default_factory=lambda: np.empty(0, dtype=np.int64),
                              repr=False)
    lateness_max_s: float = float("nan")
    detected_s: float = float("nan")
    """Seconds from the injection to the first word of it (a fault, a lost process)."""
    flushed_before: int = -1
    """Samples the file held, flushed, just before the injection (read as an SWMR reader)."""
    fate: str = ""
    """What the console last heard of the file's end: "closed", "lost" (it could not be
    finished: the window then finishes the trial from it) or '' (nothing)."""
    console_exit: int | None = None
    stderr: str = field(default="", repr=False)
    notes: list[str] = field(default_factory=list)
    """What the reader says of the file (app.trials.reader: 'unsealed (closing
    interrupted)' when it was not sealed at its close)."""

    @property
    def lost(self) -> int:
        """Ticks the loop pushed for the trial that the file does not have."""
        if self.last_pushed_tick < 0:
            return 0
        return int(np.setdiff1d(np.arange(self.last_pushed_tick + 1), self.ticks).size)


class LiveConsole:
    """tests/device/live_console.py running one trial, in a process group of its own."""

    def __init__(self, path: Path, env: dict | None = None) -> None:
        self.path = path
        self.events: list[dict] = []
        self._lock = threading.Lock()
        self.proc = subprocess.Popen(
            [sys.executable, str(CONSOLE), str(path)], cwd=ROOT, text=True,
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
            start_new_session=True, env={**os.environ, **(env or {})})
        self._stderr: list[str] = []
        self._readers = [threading.Thread(target=self._read_out, daemon=True),
                         threading.Thread(target=self._read_err, daemon=True)]
        for reader in self._readers:
            reader.start()
        started = self.wait_event(lambda e: e["event"] == "started")
        self.pids = {name: started[name] for name in ("console", "loop", "recorder")}
        self.ring = RecordRing.attach(started["ring"])
        trial = self.wait_event(lambda e: e["event"] == "TrialStarted")
        self.first_seq = int(trial["first_seq"])
        self.wait_event(lambda e: e["event"] == "RecorderNotice" and e["kind"] == "opened")

    def _read_out(self) -> None:
        with contextlib.suppress(ValueError, OSError):  # the pipe closed under it
            for line in self.proc.stdout:
                with contextlib.suppress(json.JSONDecodeError), self._lock:
                    self.events.append(json.loads(line))

    def _read_err(self) -> None:
        with contextlib.suppress(ValueError, OSError):
            for line in self.proc.stderr:
                self._stderr.append(line)

    @property
    def stderr(self) -> str:
        return "".join(self._stderr)

    def wait_event(self, predicate, timeout: float = WAIT_S) -> dict:
        deadline = time.monotonic() + timeout
        while True:
            with self._lock:
                found = next((e for e in self.events if predicate(e)), None)
            if found is not None:
                return found
            if time.monotonic() > deadline or (self.proc.poll() is not None
                                               and not self.proc.stdout.readable()):
                raise AssertionError(f"no such event within {timeout} s; saw "
                                     f"{[e['event'] for e in self.events][-8:]}; "
                                     f"stderr: {self.stderr[-2000:]}")
            time.sleep(0.01)

    def wait_ticks(self, n: int) -> None:
        """Until the loop has pushed `n` records of the trial (its ticks, not seconds)."""
        self.wait_until(lambda: self.ring.write_count - self.first_seq >= n, f"{n} ticks")

    def wait_until(self, condition, what: str, timeout: float = WAIT_S) -> None:
        deadline = time.monotonic() + timeout
        while not condition():
            if time.monotonic() > deadline:
                raise AssertionError(f"not {what} within {timeout} s: {self.stderr[-2000:]}")
            time.sleep(0.005)

    def newest_tick(self) -> int:
        records = self.ring.read_new(max(0, self.ring.write_count - 1)).records
        return int(records["tick"][-1]) if len(records) else -1

    def signal(self, who: str, number: int) -> None:
        os.kill(self.pids[who], number)

    def command(self, line: str) -> None:
        with contextlib.suppress(OSError):
            self.proc.stdin.write(line + "\n")
            self.proc.stdin.flush()

    def finish(self, timeout: float = WAIT_S) -> int | None:
        """Wait for the console and its processes to end; kill the group if they hang."""
        try:
            self.proc.wait(timeout)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(self.proc.pid, signal.SIGKILL)
            self.proc.wait(10)
            return None
        deadline = time.monotonic() + timeout
        while any(_alive(self.pids[p]) for p in ("loop", "recorder")):
            if time.monotonic() > deadline:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(self.proc.pid, signal.SIGKILL)
                break
            time.sleep(0.01)
        return self.proc.returncode

    def trial_records(self) -> np.ndarray:
        """The trial's records still in the ring (all of a short trial)."""
        start = max(self.first_seq, self.ring.write_count - self.ring.capacity)
        records = self.ring.read_new(start).records
        return records[records["state"] == int(State.RUNNING)]

    def close(self) -> None:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(self.proc.pid, signal.SIGKILL)
        with contextlib.suppress(subprocess.TimeoutExpired):
            self.proc.wait(10)
        for reader in self._readers:  # the pipes' ends: their readers stop by themselves
            reader.join(10)
        for stream in (self.proc.stdin, self.proc.stdout, self.proc.stderr):
            with contextlib.suppress(OSError):
                stream.close()
        self.ring.close()


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _stopped(pid: int) -> bool:
    with open(f"/proc/{pid}/stat") as f:
        return f.read().rsplit(")", 1)[1].split()[0] in ("T", "t")


def run_fault(fault: str, folder: Path, seed: int, disk=None) -> Outcome:
    """One live trial with `fault` injected at a random tick (from `seed`); `disk`, for
    "disk full", is tests.device.smalldisk.SmallDisk (a tmpfs, else injected)."""
    rng = np.random.default_rng(seed)
    how = "process"
    env = {}
    trigger = folder / "inject-now"
    root = folder
    if fault == "disk full":
        how = disk.kind
        root = disk.root
        if disk.kind == "injected":
            env = {"REHAB_INJECT_AT": str(trigger), "REHAB_INJECT": "enospc"}
    elif fault == "write EIO":
        how = "injected"
        env = {"REHAB_INJECT_AT": str(trigger), "REHAB_INJECT": "eio"}
    path = root / f"{fault.replace(' ', '-')}.h5"
    console = LiveConsole(path, env)
    outcome = Outcome(fault, how)
    try:
        console.wait_ticks(int(rng.integers(300, 1500)))  # 0.6-3 s into the trial
        # what the file holds first: opening it takes milliseconds, which must not count
        # in the ticks or the time to the fault
        outcome.flushed_before = _flushed(path)
        outcome.injected_tick = console.newest_tick()
        injected_at = time.monotonic()
        _inject(console, fault, disk, trigger)
        outcome.console_exit = console.finish()
        records = console.trial_records()
        if len(records):
            outcome.last_pushed_tick = int(records["tick"].max())
            faulted = records["tick"][records["fault"] != 0]
            outcome.fault_tick = int(faulted.min()) if faulted.size else -1
    finally:
        outcome.stderr = console.stderr
        console.close()
    fates = [e["kind"] for e in console.events
             if e["event"] == "RecorderNotice" and e["kind"] in ("closed", "lost")]
    outcome.fate = fates[-1] if fates else ""
    file_times = _read_back(outcome, path, console.events)
    outcome.detected_s = _detected(console.events, file_times, injected_at)
    return outcome


def _flushed(path: Path) -> int:
    """The samples the trial file holds now, as a reader sees them (what a failing disk
    cannot take back)."""
    with h5py.File(path, "r", swmr=True, locking=False) as f:
        return int(min(f["timeseries"][name].shape[0] for name in f["timeseries"]))


def _inject(console: LiveConsole, fault: str, disk, trigger: Path) -> None:
    who, _, how = fault.partition(" ")
    if who in ("loop", "recorder", "console") and how == "SIGKILL":
        console.signal(who, signal.SIGKILL)
    elif who == "group":
        os.killpg(console.proc.pid, getattr(signal, how))
    elif fault == "loop SIGSTOP":
        console.signal("loop", signal.SIGSTOP)
        console.wait_until(lambda: _stopped(console.pids["loop"]), "stopped")
        # the recorder drains what was pushed; the loop stays stopped LOOP_HELD_S more
        console.wait_until(lambda: console.ring.recorder_cursor == console.ring.write_count,
                           "drained")
        time.sleep(LOOP_HELD_S)
        console.signal("loop", signal.SIGCONT)
        console.wait_ticks(console.ring.write_count - console.first_seq + 100)
        console.command("stop")
    elif fault == "recorder SIGSTOP":
        console.signal("recorder", signal.SIGSTOP)
        try:
            console.wait_event(lambda e: e["event"] == "FaultRaised")
        finally:
            console.signal("recorder", signal.SIGCONT)
    elif fault == "console SIGSTOP":
        console.signal("console", signal.SIGSTOP)
        try:  # the loop sees the heartbeat stop (5 s on the simulator), in the ring
            console.wait_until(lambda: _ring_fault(console) == Fault.HEARTBEAT_LOST,
                               "the heartbeat's fault")
        finally:
            console.signal("console", signal.SIGCONT)
    elif fault == "disk full":
        if disk.kind == "tmpfs":
            from tests.device.smalldisk import fill

            fill(disk.root)
        else:
            trigger.touch()
    elif fault == "write EIO":
        trigger.touch()
    else:
        raise ValueError(f"unknown fault {fault!r}")


def _ring_fault(console: LiveConsole) -> int:
    records = console.ring.read_new(max(0, console.ring.write_count - 50)).records
    codes = records["fault"][records["fault"] != 0]
    return int(codes[-1]) if codes.size else 0


def _detected(events: list[dict], file_times: list[float], injected_at: float) -> float:
    """Seconds from the injection to the first word of the fault: the loop's time of the
    fault (in its event, in the file or heard by the console), or the console's hearing
    of a lost process."""
    times = [e["at"] for e in events if e["event"] == "LoopLost"] + list(file_times)
    times += [e["detail"]["monotonic_s"] for e in events
              if e["event"] == "FaultRaised" and "monotonic_s" in e.get("detail", {})]
    times = [t for t in times if t >= injected_at]
    return min(times) - injected_at if times else float("nan")


def _read_back(outcome: Outcome, path: Path, events: list[dict]) -> list[float]:
    """What the file holds into `outcome`; the loop's times of the faults it records."""
    try:
        data = read_trial(path)
    except (AppError, OSError) as exc:
        outcome.problem = str(exc)
        return []
    outcome.readable = True
    outcome.status = data.status
    outcome.notes = list(data.notes)
    outcome.ticks = np.asarray(data.channels["tick"], dtype=np.int64)
    lateness = data.channels["lateness"]
    outcome.lateness_max_s = float(np.nanmax(lateness)) if len(lateness) else float("nan")
    times = []
    for event in data.events:
        if event["kind"] in ("fault", "recording"):
            values = event["values"]
            outcome.causes.append(str(values.get("cause", "")) + " | " + event["message"])
            if isinstance(values.get("monotonic_s"), float):
                times.append(values["monotonic_s"])
    for event in events:  # what the console heard and the file could not hold
        if event["event"] == "FaultRaised":
            outcome.causes.append("console: " + str(event["detail"].get("cause", "")) +
                                  " | " + event["message"])
        elif event["event"] == "LoopLost":
            outcome.causes.append("console: loop process lost | " + event["message"])
    if outcome.fault_tick < 0:
        faulted = outcome.ticks[np.asarray(data.channels["fault"]) != 0]
        outcome.fault_tick = int(faulted.min()) if faulted.size else -1
    return times
