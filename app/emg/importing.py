"""An EMG recording into a trial file, on the trial's clock.

Two clocks meet here (docs/data-format.md, "EMG"):

* A file exported by the EMG software has its own time from 0 at its start. Trial
  time = file time + `offset_s`; 0 (the default) says the EMG recording was started
  with the trial (a trigger from the robot, or both started together), and the file
  says so in `/emg` `clock`. A lab that knows the delay between the two starts gives it.
* A live capture (device.emg.capture) stamps its samples on the monotonic clock. The
  loop's `wall_time` is monotonic time less the trial's origin, which the trial file
  keeps (`/summary` `wall_time_origin_monotonic_s`), and each sample has its nominal
  trial `time`; `trial_time_from_monotonic` maps through both, so EMG lines up with the
  samples even where ticks were late.
"""

from __future__ import annotations

import dataclasses
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from app.errors import AppError
from app.trials.reader import TrialData, read_trial
from device.emg.files import EmgData, read_emg_file
from device.recording.emgfile import write_emg

ORIGIN_KEY = "wall_time_origin_monotonic_s"


class EmgImportError(AppError):
    """EMG cannot be put into a trial as asked; the message is the one line shown."""


@dataclass(frozen=True, slots=True)
class Imported:
    trial: Path
    names: tuple[str, ...]
    muscles: tuple[str, ...]
    rate_hz: float
    n_samples: int
    first_s: float
    last_s: float
    covers: float  # share of the trial's duration the EMG covers
    notes: tuple[str, ...]


def trial_time_from_monotonic(trial: TrialData, monotonic_s) -> np.ndarray:
    """Trial time of monotonic stamps (time.monotonic(), pylsl.local_clock(): both
    CLOCK_MONOTONIC on Linux), through the trial's wall_time and its origin; beyond
    the trial's samples, extended at one sample period per period."""
    origin = trial.summary.get(ORIGIN_KEY)
    if origin is None:
        raise EmgImportError(f"trial file {trial.path.name} has no {ORIGIN_KEY} in its summary "
                             "(a headless or older trial): import the EMG from a file with "
                             "--offset instead")
    wall = np.asarray(monotonic_s, dtype=float) - float(origin)
    w, t = trial.channels["wall_time"], trial.channels["time"]
    out = np.interp(wall, w, t)
    before, after = wall < w[0], wall > w[-1]
    out[before] = t[0] + (wall[before] - w[0])
    out[after] = t[-1] + (wall[after] - w[-1])
    return out


def muscles_for(data_names: tuple[str, ...], muscles: list[str] | None) -> tuple[str, ...]:
    """The muscle under each electrode: as given (one per channel, in order), or the
    channel's own name."""
    if not muscles:
        return data_names
    if len(muscles) != len(data_names):
        raise EmgImportError(f"{len(muscles)} muscles given for {len(data_names)} EMG channels "
                             f"({', '.join(data_names)}); give one per channel, in that order")
    if len(set(muscles)) != len(muscles):
        raise EmgImportError("a muscle is named twice; give each channel its own muscle")
    return tuple(muscles)


def store(trial: TrialData, data: EmgData, trial_time_s: np.ndarray, *, muscles, clock: str,
          offset_s: float, replace: bool, notes: tuple[str, ...] = (),
          clock_offsets: tuple[tuple[float, float], ...] = ()) -> Imported:
    """The EMG into the trial's file, with its notes (the data's, `notes`, and how much of
    the trial it covers) and the clock offsets added to its stamps (trial time, offset s:
    a live LSL source's, or those pyxdf applied to an XDF recording's): in the file, not
    only said (device.recording.emgfile)."""
    names = muscles_for(data.names, muscles)
    duration = trial.n_samples * trial.sample_period_s
    inside = np.clip(trial_time_s, 0.0, duration)
    covers = float(inside[-1] - inside[0]) / duration if duration > 0 else 0.0
    notes = [*data.notes, *notes]
    if covers < 0.99:
        notes.append(f"the EMG covers {100 * covers:.0f} % of the trial "
                     f"({trial_time_s[0]:.2f}–{trial_time_s[-1]:.2f} s of {duration:.2f} s)")
    write_emg(trial.path, names=data.names, muscles=names, rate_hz=data.rate_hz,
              time_s=trial_time_s, samples=data.samples, source=data.source, clock=clock,
              offset_s=offset_s, source_file=data.path.name, replace=replace, notes=notes,
              clock_offsets=clock_offsets)
    return Imported(trial.path, data.names, names, data.rate_hz, trial_time_s.size,
                    float(trial_time_s[0]), float(trial_time_s[-1]), covers, tuple(notes))


def import_emg_file(
    trial_path: str | os.PathLike,
    emg_path: str | os.PathLike,
    *,
    muscles: list[str] | None = None,
    offset_s: float = 0.0,
    replace: bool = False,
) -> Imported:
    """Read an exported EMG file (device.emg.files) and store it in the trial's `/emg`."""
    trial = read_trial(trial_path)
    if not trial.closed:
        raise EmgImportError(f"trial file {trial.path.name} is still being recorded; import "
                             "the EMG after the trial ends")
    data = read_emg_file(emg_path)
    clock = ("file time + offset_s: the EMG recording started with the trial" if offset_s == 0
             else "file time + offset_s: the delay between the two starts, as given")
    trial_time = data.t_s + float(offset_s)
    duration = trial.n_samples * trial.sample_period_s
    # EMG wholly beside the trial normalises and shows nothing of it; far enough away the
    # times no longer increase (their steps below a double's resolution), read as damage
    if not (trial_time[0] <= duration and trial_time[-1] >= 0.0
            and (np.diff(trial_time) > 0).all()):
        raise EmgImportError(
            f"an offset of {offset_s:g} s puts the EMG at trial time {trial_time[0]:.6g}–"
            f"{trial_time[-1]:.6g} s, none of it within the trial (0–{duration:.2f} s): give "
            "the trial time of the EMG file's time 0, the delay between the two starts "
            f"(from {-data.t_s[-1]:.2f} to {duration - data.t_s[0]:.2f} s for this file)")
    return store(trial, data, trial_time, muscles=muscles, clock=clock,
                 offset_s=float(offset_s), replace=replace)


def import_capture(trial_path: str | os.PathLike, captured, *, names, muscles=None,
                   source: str, replace: bool = False, margin_s: float | None = None) -> Imported:
    """Store a live capture (device.emg.capture.Captured, monotonic stamps) in a closed
    trial file, its stamps mapped onto the trial's clock (trial_time_from_monotonic).
    With `margin_s`, only the samples from `margin_s` before the trial to `margin_s` after
    it are kept (a source that streams across trials)."""
    trial = read_trial(trial_path)
    if margin_s is not None and captured.stamps_s.size:
        t = trial_time_from_monotonic(trial, captured.stamps_s)
        end = trial.n_samples * trial.sample_period_s
        keep = (t >= -margin_s) & (t <= end + margin_s)
        captured = dataclasses.replace(captured, stamps_s=captured.stamps_s[keep],
                                       samples=captured.samples[keep])
    if not trial.closed:
        raise EmgImportError(f"trial file {trial.path.name} is still being recorded; store "
                             "the EMG after the trial ends")
    if captured.stamps_s.size < 2:
        raise EmgImportError(f"no EMG was captured{': ' + captured.error if captured.error else ''}"
                             "; check the EMG source's status before the next trial")
    data = EmgData(tuple(names), captured.rate_hz, captured.stamps_s, captured.samples, source,
                   Path(source))
    notes = list(getattr(captured, "notes", ()))  # the source's own (a trigger left out)
    if captured.missing:
        notes.append(f"{captured.missing} samples missing in the capture")
    if captured.error:
        notes.append(f"the capture ended early: {captured.error}")
    clock = ("monotonic stamps through /summary wall_time_origin_monotonic_s and "
             "/timeseries/wall_time")
    offsets = offsets_over(getattr(captured, "clock_offsets", ()), captured.stamps_s)
    if offsets:
        clock = (f"the LSL sender's stamps plus the clock offsets in clock_offsets (liblsl's "
                 f"time_correction), then {clock}")
    begun = trial_time_from_monotonic(trial, [t for t, _ in offsets]) if offsets else ()
    return store(trial, data, trial_time_from_monotonic(trial, captured.stamps_s),
                 muscles=muscles, clock=clock, offset_s=0.0, replace=replace,
                 notes=tuple(notes),
                 clock_offsets=tuple((float(t), o) for t, (_, o) in zip(begun, offsets,
                                                                          strict=True)))


def offsets_over(offsets, stamps_s: np.ndarray) -> list[tuple[float, float]]:
    """The clock offsets (first stamp, offset s) that were added over `stamps_s`
    (increasing): the one in effect at the first stamp, from that stamp, and each begun
    after it up to the last; none for no stamps."""
    if not len(offsets) or not stamps_s.size:
        return []
    first, last = float(stamps_s[0]), float(stamps_s[-1])
    before = [o for t, o in offsets if t <= first]
    head = [(first, float(before[-1]))] if before else []
    return head + [(float(t), float(o)) for t, o in offsets if first < t <= last]


def channel_names(declared, width: int) -> tuple[str, ...]:
    """A live source's channels as the window shows them and the trial file keeps them:
    the names the source declares (an LSL stream's labels) when there is one for each and
    no two alike, else EMG1…"""
    declared = tuple(declared or ())
    if len(declared) == width and len(set(declared)) == width and all(declared):
        return declared
    return tuple(f"EMG{i + 1}" for i in range(width))


CSV_UNSAFE = frozenset(',;"[]\r\n')
"""Characters a plain CSV's column name cannot hold as it is (device.emg.files: the
separator, the quote, the unit's brackets, a line's end)."""


def csv_column_names(declared, width: int) -> tuple[tuple[str, ...], str]:
    """A live source's channels as `rehab emg record` names its CSV columns: as the trial
    file does (channel_names), unless a declared name cannot be a plain CSV column as it
    is; then EMG1… and one line why (else '')."""
    names = channel_names(declared, width)
    unsafe = [n for n in names if set(n) & CSV_UNSAFE or n != n.strip()]
    if not unsafe:
        return names, ""
    return (tuple(f"EMG{i + 1}" for i in range(width)),
            f"the source's channel name {unsafe[0]!r} cannot be a CSV column (no , ; \" [ ] "
            "or spaces around it): the columns are EMG1 to "
            f"EMG{width}, in the source's order")


LIVE_MARGIN_S = 2.0
BUSY_RETRY_S = 10.0


def store_live_capture(trial_path: str | os.PathLike, captured, label: str) -> Imported:
    """What the window does when a trial's file closes while a live source streams: the
    capture's samples from LIVE_MARGIN_S before the trial to as long after, into the
    trial's `/emg`, each channel under the name its source declares (an LSL stream's
    labels: the muscles, as a lab names them) or EMG1…"""
    names = channel_names(captured.labels, captured.samples.shape[1])
    return when_free(lambda: import_capture(trial_path, captured, names=names, source=label,
                                            margin_s=LIVE_MARGIN_S))


# what HDF5 says when another thread of the window holds the file open this very moment
# (for its report): for writing, or with the other locking flag
BUSY_WORDS = ("already open", "file locking flag values don't match")


def when_free(work):
    """`work()` (reading and writing a trial file), tried again for up to BUSY_RETRY_S while
    HDF5 refuses to open the file because the window is reading it for its report."""
    import time

    from device.errors import RecordingError

    deadline = time.monotonic() + BUSY_RETRY_S
    while True:
        try:
            return work()
        except RecordingError as exc:
            if not any(w in str(exc) for w in BUSY_WORDS) or time.monotonic() > deadline:
                raise
            time.sleep(0.1)
