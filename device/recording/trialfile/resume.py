"""A trial file taken over from a writer that died with it open (a killed recorder): what
`TrialFileWriter.resume` finds in it (docs/data-format.md, Crash safety).

The dead writer left HDF5's "open for writing" flags set (cleared here, as `h5clear -s`
does) and, when it died between two datasets of a batch, channels of unequal lengths
and rows reserved but never written (the fill value, `tick` −1). Every channel is cut
to the samples all of them hold whole, and the events to the rows written, so that the
samples appended next follow on from the last whole one.
"""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from device.errors import RecordingError
from device.recording.record import Channel
from device.recording.trialfile.layout import CHUNK_CACHE_BYTES, LIBVER, _disk_error
from device.recording.trialfile.recover import clear_open_flags
from device.recording.trialfile.seal import check_header
from device.recording.trialfile.verify import Damaged, check_heaps


def adopt(path: Path, channels: tuple[Channel, ...]):
    """(file, dataset ids, events dataset, samples, events) of the trial file at `path`,
    open for writing, cut to its whole samples and written events. Nothing in it changes
    unless its header matches its digest (device.recording.trialfile.seal): the writer
    seals the file when it closes it, never over damage."""
    _check(path)
    try:
        f = h5py.File(path, "r+", libver=LIBVER, locking=False,
                      rdcc_nbytes=CHUNK_CACHE_BYTES)
    except (OSError, RuntimeError) as exc:
        raise _disk_error(path, "reopen", exc) from exc
    try:
        series = f["timeseries"]
        missing = [c.name for c in channels if c.name not in series]
        if missing:
            raise RecordingError(f"{path.name} lacks the channels {', '.join(missing)}; it "
                                 "is not a trial file of this recorder")
        n = min(series[c.name].shape[0] for c in channels)
        ticks = series["tick"][:n]
        unwritten = np.flatnonzero(ticks < 0)
        if unwritten.size:
            n = int(unwritten[0])
        datasets = []
        for c in channels:
            tail = () if c.width == 1 else (c.width,)
            dataset = series[c.name]
            dataset.resize((n, *tail))
            datasets.append((c.name, dataset.id, tail))
        events = f["events"]
        kinds = events["kind"][()] if events.shape[0] else np.empty(0, dtype=object)
        written = np.flatnonzero(np.asarray([len(k) == 0 for k in kinds], dtype=bool))
        n_events = int(written[0]) if written.size else int(events.shape[0])
        events.resize((n_events,))
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        f.close()
        if isinstance(exc, RecordingError):
            raise
        raise _disk_error(path, "take over", exc) from exc
    return f, datasets, events, n, n_events


def _check(path: Path) -> None:
    """The dead writer's flags cleared, then nothing that would hang libhdf5
    (verify.check_heaps) and a header as its digest says."""
    try:
        check_heaps(path)
        clear_open_flags(path)
        with h5py.File(path, "r", locking=False) as f:
            check_header(f)
    except Damaged as exc:
        raise RecordingError(f"trial file {path}: {exc.problem}; it was not taken over"
                             ) from None
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        raise _disk_error(path, "take over", exc) from exc
