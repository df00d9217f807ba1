"""EMG from a LabRecorder recording (XDF) into a trial, placed through the robot's own
stream.

A lab records every LSL stream into one XDF file: the EMG software's stream and the
console's `rehab-robot` stream and its markers (`rehab gui --lsl-outlet`,
device.lsl.outlet). pyxdf reads the file and puts every stream on the recording computer's
clock (LabRecorder's clock-offset chunks; `synchronize_clocks`); the stamps are kept as
they were sent (no dejittering), since the robot's are the exact times of its sensor reads.
The EMG stream's clock offsets pyxdf applied are kept with the EMG (`/emg`
`clock_offsets`, each at the trial time it was measured: `applied_offsets`).

The trial's own records say when each tick's sensor was read on the console's clock
(`/summary` wall_time_origin_monotonic_s + `wall_time`), and the robot stream carries the
same positions at those moments on the recording's clock. The offset between the two
clocks is found where the trial's first position appears in the robot stream, and kept
only when, at that offset, at least 99 % of the trial's ticks are in the stream with
exactly their positions (a double crosses LSL and XDF unchanged). A recording of another
trial, of another console, or without the robot stream is refused in one line. The EMG's
stamps, less that offset, are monotonic times of the console, and
app.emg.importing.trial_time_from_monotonic puts them on the trial's clock, as for a live
capture. Each channel is read in volts by the unit its stream declares, times its
`scaling_factor` where it declares one (a raw integer stream's count, core.emg.units). A
channel an amplifier's app appends to the stream that is not EMG (a trigger channel such
as BrainAmpSeries' `triggerStream` of unit `code`, LiveAmp's accelerometer, sample counter
or sync pulse: core.emg.units.not_emg_channel) is left out with a note; any other channel
that is not an EMG voltage is refused in one line, as by device.lsl.inlet.

LabRecorder goes on recording an EMG sender that stopped and came back (liblsl recovers
it by its source id) into the same stream: a hole, and after it perhaps samples at
another rate under the rate the stream's header declares. A hole is noted with where it
is and how many samples are missing; a stretch of the stream that ran at another rate
than declared is refused in one line, since every envelope and MVC is filtered at the
declared rate.
"""

from __future__ import annotations

import itertools
import logging
import os
import struct
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from app.emg.importing import EmgImportError, Imported, store, trial_time_from_monotonic
from app.trials.reader import TrialData, read_trial
from core.emg.units import (
    emg_type,
    left_out_notes,
    not_emg_channel,
    scaling_factor,
    volts_per_unit,
)
from device.emg.emgtext import beyond_range
from device.emg.files import EmgData
from device.lsl.outlet import EVENT_STREAM, ROBOT_CHANNELS, ROBOT_STREAM

MATCH_TOLERANCE_S = 2.5e-4
"""A tick and a robot-stream sample are the same reading when their stamps, on one clock,
differ by less than this (an eighth of a 2 ms tick: the clock offsets LabRecorder measured
move by microseconds)."""
MATCHED_SHARE = 0.99
CANDIDATES = 50
"""Places where the trial's first position appears in the stream that are tried (the
handle at rest repeats a position; the trial's whole run of positions does not)."""
GAP_S = 0.1
"""Stamps further apart than this (and than ten sample periods) are a hole in the stream."""
RATE_TOLERANCE = 0.05
"""A stretch between holes of at least a second whose stamps run this far from the
declared rate is another rate."""


@dataclass(frozen=True, slots=True, eq=False)
class XdfStream:
    name: str
    type: str
    source_id: str
    rate_hz: float
    channel_format: str
    labels: tuple[str, ...]
    units: tuple[str, ...]
    scaling_factors: tuple[str, ...]
    stamps: np.ndarray
    values: object  # (k, C) numbers, or a list of lists of strings for a marker stream
    types: tuple[str, ...] = ()
    clock_times: np.ndarray = field(default_factory=lambda: np.empty(0))
    """When LabRecorder measured each clock offset of the stream, on the sender's clock
    (it writes its own time less the offset: XDF's ClockOffset CollectionTime)."""
    clock_values: np.ndarray = field(default_factory=lambda: np.empty(0))
    """Each offset measured: the recording computer's clock less the sender's, s."""


class _Heard(logging.Handler):
    """What pyxdf says while it reads: it skips a damaged chunk with an error in its log
    and goes on, which must reach the researcher as a note, not a line on stderr."""

    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.said: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.said.append(" ".join(record.getMessage().split()))


def read_xdf(path: str | os.PathLike) -> tuple[list[XdfStream], tuple[str, ...]]:
    """Every stream of an XDF file, on the recording computer's clock, and what pyxdf said
    of damage it skipped; one line when the file cannot be read."""
    import pyxdf  # only here: a console that never opens an XDF file never loads it

    path = Path(path)
    logger = logging.getLogger("pyxdf")
    heard, propagate = _Heard(), logger.propagate
    logger.addHandler(heard)
    logger.propagate = False
    try:
        streams, _ = pyxdf.load_xdf(str(path), synchronize_clocks=True,
                                    dejitter_timestamps=False)
        read = [_stream(s) for s in streams]
    except (OSError, ValueError, KeyError, IndexError, EOFError, RuntimeError, TypeError,
            AttributeError, SyntaxError, struct.error) as exc:
        # SyntaxError: xml.etree's ParseError, a damaged stream header; struct.error, a
        # chunk cut short
        raise EmgImportError(f"XDF file {path}: cannot be read ({type(exc).__name__}: "
                             f"{' '.join(str(exc).split())}); record it again with "
                             "LabRecorder") from None
    finally:
        logger.removeHandler(heard)
        logger.propagate = propagate
    damage = tuple(dict.fromkeys(heard.said))
    notes = (f"the recording is damaged: pyxdf skipped what it could not read ("
             f"{'; '.join(damage[:3])}{'; …' if len(damage) > 3 else ''}); check the EMG",
             ) if damage else ()
    return read, notes


def _first(info: dict, key: str, default: str = "") -> str:
    value = info.get(key)
    if isinstance(value, list):
        value = value[0] if value else None
    return default if value is None else str(value)


def _stream(raw: dict) -> XdfStream:
    info = raw["info"]
    labels, units, factors, types = [], [], [], []
    desc = info.get("desc")
    channels = (desc[0] or {}).get("channels") if desc else None
    for channel in ((channels[0] or {}).get("channel") or []) if channels else []:
        labels.append(_first(channel or {}, "label"))
        units.append(_first(channel or {}, "unit"))
        factors.append(_first(channel or {}, "scaling_factor").strip())
        types.append(_first(channel or {}, "type").strip())
    stamps = np.asarray(raw.get("time_stamps", []), dtype=float)
    values = raw.get("time_series")
    if isinstance(values, np.ndarray):
        values = values.reshape(len(stamps), -1) if values.size else np.empty((0, 0))
    return XdfStream(_first(info, "name"), _first(info, "type"), _first(info, "source_id"),
                     float(_first(info, "nominal_srate", "0") or 0),
                     _first(info, "channel_format"), tuple(labels), tuple(units), tuple(factors),
                     stamps, values, tuple(types),
                     np.asarray(raw.get("clock_times", []), dtype=float),
                     np.asarray(raw.get("clock_values", []), dtype=float))


def clock_offset(trial: TrialData, robot: XdfStream, name: str) -> float:
    """Recording clock minus the console's monotonic clock, from where the trial's ticks
    are in the robot stream (module docstring); refused in one line when they are not."""
    origin = trial.summary.get("wall_time_origin_monotonic_s")
    if origin is None:
        raise EmgImportError(f"trial file {trial.path.name} has no clock origin (a headless "
                             "or older trial): import the EMG from an exported file instead")
    x, y = (_robot_column(robot, label) for label in ("position_x", "position_y"))
    positions = trial.channels["position"]
    ticks = float(origin) + trial.channels["wall_time"]
    found = np.flatnonzero((robot.values[:, x] == positions[0, 0])
                           & (robot.values[:, y] == positions[0, 1]))
    best = 0.0
    for j in found[:CANDIDATES]:
        offset = robot.stamps[j] - ticks[0]
        at = np.clip(np.searchsorted(robot.stamps, ticks + offset), 1, len(robot.stamps) - 1)
        nearest = np.where(np.abs(robot.stamps[at - 1] - ticks - offset)
                           < np.abs(robot.stamps[at] - ticks - offset), at - 1, at)
        same = ((np.abs(robot.stamps[nearest] - ticks - offset) < MATCH_TOLERANCE_S)
                & (robot.values[nearest, x] == positions[:, 0])
                & (robot.values[nearest, y] == positions[:, 1]))
        share = float(np.mean(same))
        if share >= MATCHED_SHARE:
            return float(offset)
        best = max(best, share)
    raise EmgImportError(
        f"XDF file {name}: its {ROBOT_STREAM} stream does not hold trial "
        f"{trial.path.name} (at best {100 * best:.0f} % of its ticks at their times and "
        "positions): record the trial with the console's LSL outlet on (rehab gui "
        "--lsl-outlet) and give the recording that was running during it")


def applied_offsets(trial: TrialData, emg: XdfStream,
                    offset: float) -> tuple[tuple[float, float], ...]:
    """LabRecorder's clock offsets of the EMG stream, which pyxdf applied (its
    synchronize_clocks adds to the sender's stamps a line fitted through them, one per
    stretch between clock resets), each (trial time it was measured, offset s), in time
    order, for the trial file's `/emg` `clock_offsets`: what was added to the stamps is
    kept, not only applied. A measurement's time is on the sender's clock; plus its offset
    it is on the recording's, and less `offset` (recording clock − console clock) on the
    console's."""
    if not emg.clock_values.size:
        return ()
    when = trial_time_from_monotonic(trial, emg.clock_times + emg.clock_values - offset)
    order = np.argsort(when, kind="stable")
    return tuple((float(when[k]), float(emg.clock_values[k])) for k in order)


def _robot_column(robot: XdfStream, label: str) -> int:
    if label in robot.labels:
        return robot.labels.index(label)
    return next(k for k, (_, _, name, _, _) in enumerate(ROBOT_CHANNELS) if name == label)


def emg_stream(streams: list[XdfStream], name: str | None, path: Path) -> XdfStream:
    """The EMG stream asked for by name, else the one regular numeric stream of type EMG."""
    numeric = [s for s in streams if s.channel_format != "string" and s.rate_hz > 0
               and s.name not in (ROBOT_STREAM, EVENT_STREAM)]
    if name is not None:
        chosen = [s for s in numeric if s.name == name]
        what = f"no regular numeric stream named {name!r}"
    else:
        chosen = [s for s in numeric if s.type.lower() == "emg"]
        what = "no EMG stream (type EMG)"
    if len(chosen) != 1:
        seen = ", ".join(f"{s.name} ({s.type or 'no type'})" for s in numeric) or "none"
        problem = what if not chosen else f"{len(chosen)} streams match"
        raise EmgImportError(f"XDF file {path.name}: {problem}; its numeric streams: {seen}. "
                             "Name the EMG stream with --stream")
    return chosen[0]


def emg_volts(stream: XdfStream, path: Path,
              unit: str | None) -> tuple[np.ndarray, list[int], tuple[str, ...]]:
    """The stream's EMG channels in volts by each channel's declared unit, or `unit` for
    channels that declare none (a declared one that disagrees is refused), times its
    declared scaling factor; which columns they are; and one line naming the channels left
    out as not EMG (core.emg.units.not_emg_channel). Any other channel that is not an EMG
    voltage is refused in one line."""
    count = stream.values.shape[1]

    def declared(values: tuple[str, ...]) -> list[str]:
        return (list(values) + [""] * count)[:count]

    labels, units = declared(stream.labels), declared(stream.units)
    factors, types = declared(stream.scaling_factors), declared(stream.types)
    where = f"XDF file {path.name}: stream {stream.name}"
    kept, scales, left_out, said = [], [], [], []
    for k, written in enumerate(units):
        channel = labels[k] or f"channel {k + 1}"
        why = not_emg_channel(labels[k], types[k], written)
        if why is not None:
            left_out.append(f"{channel}, {why}")
            continue
        factor = scaling_factor(factors[k])
        if factor is None:
            raise EmgImportError(f"{where} gives {channel} a scaling_factor of "
                                 f"{factors[k]!r}, not a positive number")
        if written and unit and volts_per_unit(written) != volts_per_unit(unit):
            raise EmgImportError(f"{where} declares {channel} in {written!r}, not {unit!r} as "
                                 "given")
        scale = volts_per_unit(written or unit or "")
        if scale is None:
            said = f"gives {channel} in {written!r}" if written else \
                f"does not say the unit of {channel}"
            raise EmgImportError(f"{where} {said}, not a voltage: give it with --unit (V, mV "
                                 "or uV)")
        if not emg_type(types[k]):
            raise EmgImportError(f"{where} gives {channel} as type {types[k]!r}, not EMG, "
                                 "ExG, EEG, bipolar or AUX: a stream of EMG channels only is "
                                 "imported")
        kept.append(k)
        scales.append(scale * factor)
        said.append(f"in {written!r} as the stream declares" if written else
                    f"in {unit!r} as given with --unit")
    if not kept:
        raise EmgImportError(f"{where} has no EMG channel, only {'; '.join(left_out)}")
    notes = left_out_notes(f"stream {stream.name}", left_out)
    volts = np.asarray(stream.values, dtype=float)[:, kept] * np.asarray(scales)
    for c, k in enumerate(kept):
        problem = beyond_range(labels[k] or f"channel {k + 1}", volts[:, c], said[c])
        if problem:
            raise EmgImportError(f"{where}: {problem}: give the unit the amplifier sends "
                                 "with --unit (V, mV or uV), or correct the stream's")
    return volts, kept, notes


def continuity(stream: XdfStream, trial_time: np.ndarray, path: Path) -> tuple[str, ...]:
    """A note for the stream's holes; refused in one line where it ran at another rate than
    it declares (module docstring)."""
    period = 1.0 / stream.rate_hz
    steps = np.diff(stream.stamps)
    holes = np.flatnonzero(steps > max(GAP_S, 10 * period))
    bounds = np.concatenate(([0], holes + 1, [stream.stamps.size]))
    for first, end in itertools.pairwise(bounds):
        span = stream.stamps[end - 1] - stream.stamps[first]
        if span >= 1.0:
            rate = (end - 1 - first) / span
            if abs(rate * period - 1.0) > RATE_TOLERANCE:
                raise EmgImportError(
                    f"XDF file {path.name}: stream {stream.name} ran at about {rate:.0f} Hz "
                    f"from trial time {trial_time[first]:.1f} s, not the "
                    f"{stream.rate_hz:g} Hz it declares (the EMG software restarted at another "
                    "rate?): record again, or export each part from the EMG software")
    if not holes.size:
        return ()
    longest = holes[np.argmax(steps[holes])]
    missing = int(np.sum(np.round(steps[holes] / period) - 1))
    where = (f"for {steps[longest]:.1f} s at trial time {trial_time[longest]:.1f} s"
             if holes.size == 1 else f"{holes.size} times, longest {steps[longest]:.1f} s at "
             f"trial time {trial_time[longest]:.1f} s")
    return (f"the EMG stream {stream.name} stopped {where} ({missing} samples missing): the "
            "EMG has a hole there",)


def import_xdf(trial_path: str | os.PathLike, xdf_path: str | os.PathLike, *,
               stream: str | None = None, unit: str | None = None,
               muscles: list[str] | None = None, replace: bool = False) -> Imported:
    """Store the EMG stream of a LabRecorder recording in a closed trial's `/emg`, on the
    trial's clock (module docstring)."""
    trial = read_trial(trial_path)
    if not trial.closed:
        raise EmgImportError(f"trial file {trial.path.name} is still being recorded; import "
                             "the EMG after the trial ends")
    path = Path(xdf_path)
    streams, damage = read_xdf(path)
    robots = [s for s in streams if s.name == ROBOT_STREAM and s.channel_format != "string"
              and len(s.stamps)]
    if not robots:
        raise EmgImportError(f"XDF file {path.name} has no {ROBOT_STREAM} stream to place the "
                             "EMG on the trial's clock: record with the console's LSL outlet "
                             "on (rehab gui --lsl-outlet)")
    offsets = []
    for robot in robots:  # one per console on the network; the trial's is the one that fits
        try:
            offsets.append(clock_offset(trial, robot, path.name))
        except EmgImportError as refused:
            problem = refused
    if not offsets:
        raise problem
    offset = offsets[0]
    emg = emg_stream(streams, stream, path)
    if not len(emg.stamps):
        raise EmgImportError(f"XDF file {path.name}: stream {emg.name} has no samples")
    volts, kept, left_out = emg_volts(emg, path, unit)
    labels = list(emg.labels) + [""] * (emg.values.shape[1] - len(emg.labels))
    names = tuple(labels[k] or f"{emg.name}-{k + 1}" for k in kept)
    trial_time = trial_time_from_monotonic(trial, emg.stamps - offset)
    holes = continuity(emg, trial_time, path)
    markers = sum(len(s.stamps) for s in streams if s.name == EVENT_STREAM)
    notes = (f"placed through the {ROBOT_STREAM} stream: recording clock − console clock = "
             f"{offset:.6f} s; {markers} robot markers in the recording", *left_out, *holes,
             *damage)
    data = EmgData(names, emg.rate_hz, trial_time, volts, "xdf", path, notes)
    applied = applied_offsets(trial, emg, offset)
    clock = ("LSL stamps of the XDF recording"
             + (", plus the line pyxdf fitted through LabRecorder's clock offsets of the EMG "
                "stream (in clock_offsets)" if applied else "")
             + f", less the offset at which the trial's ticks are in its {ROBOT_STREAM} stream")
    return store(trial, data, trial_time, muscles=muscles, clock=clock, offset_s=0.0,
                 replace=replace, clock_offsets=applied)
