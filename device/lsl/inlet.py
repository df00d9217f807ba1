"""An EMG stream of the Lab Streaming Layer, read in volts on this machine's clock.

Any numeric channel format a sender declares (int8, int16, int32, int64, float32,
double64) is pulled into a buffer of that very format, then converted to volts by the
unit each channel declares in the stream's description (`desc/channels/channel/unit`, the
XDF meta-data convention LabRecorder keeps): V, mV, µV (uV, microvolts) or nV. Pulling an
integer stream into a float buffer (as this inlet once did) made liblsl write integers
into memory read as doubles: ±1e294 and NaN. A channel without a unit, or with one that is
not a voltage, is refused in one line, unless the caller says what the stream carries
(`unit=`); a declared unit that contradicts the caller's is refused too. A channel's
`scaling_factor` (the worth of one count of a raw integer stream, core.emg.units) is
applied: without it a BrainAmp's int16 counts of 0.1 µV were read as whole microvolts, ten
times too large. The labels the stream declares name the muscles (`labels`).

An amplifier's LSL app may append channels that are not EMG to its data stream: a trigger
channel of event codes (BrainAmpSeries' `triggerStream`, unit `code`; LiveAmp's
`DeviceTrigger` and `STETrigger…`), its accelerometer, a sample counter, a sync pulse
(core.emg.units.not_emg_channel). Such a channel is left out, and `notes` says so in one
line; the other channels are read when their unit is a voltage and their type EMG-like
(core.emg.units.EMG_TYPES), and the stream is refused in one line for any other channel
(one in milliGs that does not say it is an accelerometer).

The inlet puts a remote sender's stamps onto this machine's clock by adding liblsl's
clock offset (`time_correction`, re-estimated by liblsl every few seconds) to each chunk
as it reads it, so its stamps are this machine's monotonic seconds, and does nothing
else: the stamps come as the sender gave them, and what the capture does to them is said
with the trial's EMG (device.emg.capture). It adds the offset itself rather than asking
liblsl to (`proc_clocksync`, "equivalent to manually adding the time_correction()" in
pylsl's words) so that it knows which offsets it added and from which sample:
`clock_offsets` keeps each, and the trial file's EMG keeps them (docs/data-format.md,
`/emg` `clock_offsets`); with proc_clocksync they were applied and told to nobody.
liblsl's other post-processing would hide what the record must say. `proc_monotonize`
sets a stamp that goes back equal to the one before (liblsl's time_postprocessor: `if
(value < last_value_) value = last_value_`): the trial file's EMG times must increase, so
the capture would still move it, and its note would say "by up to 0.0 ms", the sender's
1.5 ms lost. `proc_dejitter` replaces every stamp by a line fitted over the last 90 s (a
recursive least-squares fit on the sample count): 100 samples lost at the sender (a 50 ms
step) came as 1.4 ms steps spread over the next ones, counted as 125 missing, and no
stamp was the sender's (measured on this machine's loopback, tests/device/test_lsl.py).
"""

from __future__ import annotations

import numpy as np

from core.emg.units import (
    emg_type,
    left_out_notes,
    not_emg_channel,
    scaling_factor,
    volts_per_unit,
)
from device.lsl.library import LslError, channel_descriptions, pylsl, summary

DUPLICATE_LOOK_S = 1.0
"""How long to look for a second stream of the name: liblsl answers resolves in waves, and
with discovery confined to this machine the second stream came after 0.5 s."""
def _formats(module) -> dict[int, type]:
    """liblsl's numeric channel formats and the numpy type liblsl writes for each."""
    return {module.cf_float32: np.float32, module.cf_double64: np.float64,
            module.cf_int8: np.int8, module.cf_int16: np.int16,
            module.cf_int32: np.int32, module.cf_int64: np.int64}


class LslEmgInlet:
    """An EMG stream's samples in volts, stamped on this machine's monotonic clock.

    Found by name, or else by type (`EMG`). Refused with one line when there is none,
    more than one, it is not a regular numeric stream with the channels and rate asked
    for, or its channels' units are not voltages (module docstring)."""

    def __init__(self, name: str | None = None, *, stream_type: str = "EMG",
                 timeout_s: float = 3.0, channels: int | None = None,
                 rate_hz: float | None = None, buffer_s: int = 60,
                 unit: str | None = None) -> None:
        lsl = pylsl()
        prop, value = ("name", name) if name else ("type", stream_type)
        found = lsl.resolve_byprop(prop, value, minimum=1, timeout=timeout_s)
        what = f"LSL stream {'named' if name else 'of type'} {value!r}"
        if not found:
            raise LslError(f"no {what} found in {timeout_s:g} s: start the EMG software's LSL "
                           "stream on this network (rehab emg streams lists what is seen)")
        # resolving returns at the first stream; a second one of the name would be
        # recorded in its place by chance, so look a moment longer for another
        found = lsl.resolve_byprop(prop, value, minimum=2, timeout=DUPLICATE_LOOK_S) or found
        if len(found) > 1:
            sources = ", ".join(f"{i.source_id() or 'no source id'} on {i.hostname()}"
                                for i in found)
            raise LslError(f"{len(found)} LSL streams {'named' if name else 'of type'} "
                           f"{value!r} found ({sources}): stop the extra one or rename it, so "
                           "the recording cannot take the wrong one")
        info = found[0]
        self.summary = summary(info)
        fmt = _formats(lsl).get(info.channel_format())
        if fmt is None:
            raise LslError(f"{what} carries text, not EMG samples")
        if info.nominal_srate() <= 0:
            raise LslError(f"{what} has no regular rate (irregular stream), not EMG")
        if channels is not None and info.channel_count() != channels:
            raise LslError(f"{what} has {info.channel_count()} channels, {channels} expected: "
                           "check the EMG software's stream settings")
        if rate_hz is not None and abs(info.nominal_srate() - rate_hz) > 0.01 * rate_hz:
            raise LslError(f"{what} runs at {info.nominal_srate():g} Hz, {rate_hz:g} Hz "
                           "expected")
        # no post-processing: the clock offset is added in `read`, and neither
        # proc_dejitter nor proc_monotonize is asked for (module docstring)
        self._inlet = lsl.StreamInlet(info, max_buflen=buffer_s,
                                      processing_flags=lsl.proc_none)
        self._no_estimate = lsl.util.TimeoutError
        self.clock_offset_s = 0.0
        """The clock offset added to the latest stamps (s): liblsl's estimate of this
        machine's clock less the sender's."""
        self.clock_offsets: list[tuple[float, float]] = []
        """Each clock offset added (s) with the first stamp it was added to (this
        machine's monotonic s), in order: each holds until the next begins."""
        try:  # a resolved stream's info is its header; the description comes from the sender
            described = channel_descriptions(self._inlet.info(timeout=timeout_s))
        except Exception as exc:  # pylsl's TimeoutError or LostError
            raise LslError(f"the {what} did not send its description in {timeout_s:g} s "
                           f"({type(exc).__name__})") from None
        kept, self.volts_per_unit, self.notes = _scales(what, described, unit)
        described = [described[k] for k in kept]
        self.labels = tuple(d["label"] for d in described) if all(
            d["label"] for d in described) else ()
        self.units = tuple(d["unit"] or (unit or "") for d in described)
        self.rate_hz = float(info.nominal_srate())
        self.channel_count = len(kept)
        # only the EMG channels are read; None reads them all without a copy
        self._columns = None if len(kept) == info.channel_count() else np.asarray(kept)
        # liblsl writes samples of the stream's own format: the buffer must be of it, and
        # as wide as the stream, trigger channels and all
        self._buffer = np.empty((max(1024, int(self.rate_hz)), info.channel_count()),
                                dtype=fmt)

    def open(self, timeout_s: float = 3.0) -> LslEmgInlet:
        try:
            self._inlet.open_stream(timeout=timeout_s)
            # the first clock-offset estimate takes a while; have it before the trial, not
            # in the first read (which would then hold the first samples back)
            self.clock_offset_s = float(self._inlet.time_correction(timeout=timeout_s))
        except Exception as exc:  # pylsl raises its TimeoutError or LostError
            raise LslError(f"the LSL stream {self.summary.name!r} did not open in "
                           f"{timeout_s:g} s ({type(exc).__name__})") from None
        return self

    def read(self, timeout_s: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Samples waiting (up to a second's worth): (monotonic stamps (k,), volts (k, C))."""
        try:
            # min_samples=1: return as soon as anything came, not when the buffer is full
            _, stamps = self._inlet.pull_chunk(timeout=timeout_s,
                                               max_samples=self._buffer.shape[0],
                                               dest_obj=self._buffer, min_samples=1)
            if len(stamps):
                offset = self._latest_offset()
        except Exception as exc:  # pylsl's LostError: the sender went away
            raise LslError(f"the LSL stream {self.summary.name!r} was lost "
                           f"({type(exc).__name__}); check the EMG software") from None
        n = len(stamps)
        samples = self._buffer[:n] if self._columns is None else \
            self._buffer[:n, self._columns]
        corrected = np.asarray(stamps, dtype=float)
        if n:
            corrected += offset
            if not self.clock_offsets or self.clock_offsets[-1][1] != offset:
                self.clock_offsets.append((float(corrected[0]), offset))
            self.clock_offset_s = offset
        return corrected, samples.astype(float) * self.volts_per_unit

    def _latest_offset(self) -> float:
        """liblsl's latest estimate, at once (it re-estimates in the background); the last
        one added while it has none (being re-estimated after the stream recovered)."""
        try:
            return float(self._inlet.time_correction(timeout=0.0))
        except self._no_estimate:
            return self.clock_offset_s

    def close(self) -> None:
        self._inlet.close_stream()


def _scales(what: str, described: list[dict[str, str]],
            given: str | None) -> tuple[list[int], np.ndarray, tuple[str, ...]]:
    """The EMG channels' indices, their volts per stored number (from the declared units
    and scaling factors), and one line naming the channels left out as not EMG (module
    docstring)."""
    given_scale = None
    if given is not None:
        given_scale = volts_per_unit(given)
        if given_scale is None:
            raise LslError(f"unit {given!r} given for the {what} is not a voltage: give V, mV "
                           "or uV")
    kept, scales, left_out = [], [], []
    for k, d in enumerate(described, start=1):
        name = d["label"] or f"channel {k}"
        why = not_emg_channel(d["label"], d["type"], d["unit"])
        if why is not None:
            left_out.append(f"{name}, {why}")
            continue
        factor = scaling_factor(d["scaling_factor"])
        if factor is None:
            raise LslError(f"the {what} gives {name} a scaling_factor of "
                           f"{d['scaling_factor']!r}, not a positive number: correct it in "
                           "the EMG software's stream settings")
        if not d["unit"]:
            if given_scale is None:
                raise LslError(f"the {what} does not say the unit of {name}: declare each "
                               "channel's unit in the stream's description (V, mV or uV), or "
                               "give it (lsl:NAME@uV)")
            scale = given_scale
        else:
            scale = volts_per_unit(d["unit"])
            if scale is None:
                raise LslError(f"the {what} gives {name} in {d['unit']!r}, not a voltage: EMG "
                               "is read in V, mV or uV (switch that channel off in the EMG "
                               "software's stream settings)")
            if given_scale is not None and scale != given_scale:
                raise LslError(f"the {what} declares {name} in {d['unit']!r}, not in "
                               f"{given!r} as given: leave the unit out or correct it")
        if not emg_type(d["type"]):
            raise LslError(f"the {what} gives {name} as type {d['type']!r}, not EMG, ExG, "
                           "EEG, bipolar or AUX: switch that channel off in the EMG "
                           "software's stream settings")
        kept.append(k - 1)
        scales.append(scale * factor)
    if not kept:
        raise LslError(f"the {what} has no EMG channel, only "
                       f"{', '.join(left_out)}")
    return kept, np.asarray(scales, dtype=float), left_out_notes(f"the {what}", left_out)
