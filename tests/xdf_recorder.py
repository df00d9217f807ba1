"""A small LabRecorder for the tests: real pylsl inlets on the streams asked for, drained on
threads, written as an XDF 1.0 file.

The layout is XDF 1.0's (sccn/xdf, "Specifications"): the magic `XDF:`, then chunks of
[NumLengthBytes 1|4|8][Length, counting the tag][Tag uint16][Content], little-endian: a
FileHeader (tag 1, XML), per stream a StreamHeader (tag 2: stream id uint32, the stream's
full info XML as liblsl gives it), Samples (tag 3: stream id, a variable-length sample count,
then per sample a time-stamp byte 8 and the double stamp, and the values in the stream's
format, or for strings a variable-length length and the bytes per channel), ClockOffset
(tag 4: stream id, collection time and offset, doubles; the collection time on the
sender's clock, this clock's time less the offset, as LabRecorder's XDF writer writes it)
and a StreamFooter (tag 6, XML).
The stamps are the sender's (no clock correction in the inlet), and the clock offsets are
what liblsl's time_correction measures, as LabRecorder records them; pyxdf then puts every
stream on this computer's clock. All senders here share this machine's clock, so a test
plays a sender on another computer by stamping its samples `ahead_s` seconds ahead and
giving the recorder the same (`clocks_ahead`): its offsets are then what LabRecorder would
have measured from that computer.
"""

from __future__ import annotations

import contextlib
import struct
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import numpy as np
import pylsl

from tests.patience import HANG_S

_LITTLE_ENDIAN = {pylsl.cf_float32: "<f4", pylsl.cf_double64: "<f8", pylsl.cf_int8: "<i1",
                  pylsl.cf_int16: "<i2", pylsl.cf_int32: "<i4", pylsl.cf_int64: "<i8",
                  pylsl.cf_string: None}


def _varlen(n: int) -> bytes:
    if n < 256:
        return b"\x01" + struct.pack("<B", n)
    if n < 2**32:
        return b"\x04" + struct.pack("<I", n)
    return b"\x08" + struct.pack("<Q", n)


def _chunk(tag: int, content: bytes) -> bytes:
    return _varlen(len(content) + 2) + struct.pack("<H", tag) + content


class _Take(threading.Thread):
    def __init__(self, info):
        super().__init__(daemon=True)
        self.inlet = pylsl.StreamInlet(info, max_buflen=600, recover=False)
        self.info = self.inlet.info(5.0)
        self.inlet.open_stream(5.0)
        self.stamps, self.values = [], []
        self.offsets = [(pylsl.local_clock(), self.inlet.time_correction(5.0))]
        self.stopping = threading.Event()

    def run(self):
        string = self.info.channel_format() == pylsl.cf_string
        while not self.stopping.is_set():
            try:
                x, t = self.inlet.pull_chunk(timeout=0.1)
            except pylsl.util.LostError:
                break
            if t:
                self.stamps.extend(t)
                self.values.extend(x if string else np.asarray(x).tolist())


def _resolve(source_id: str):
    return pylsl.resolve_byprop("source_id", source_id, 1, 10.0)[0]


class XdfRecorder:
    """Records the streams whose source ids are given until `stop(path)` writes the file."""

    def __init__(self, source_ids, clocks_ahead: dict[str, float] | None = None):
        self.source_ids = list(source_ids)
        self.clocks_ahead = dict(clocks_ahead or {})
        """Seconds each sender's clock (by source id) runs ahead of this machine's: its
        recorded clock offsets (this clock minus the sender's) are that much lower."""
        self.written: dict[str, list[tuple[float, float]]] = {}
        """The clock offsets `stop` wrote for each stream (by source id): (collection time
        on the sender's clock, offset s), the known offsets a reader must find."""
        # the streams resolved in one wave and their inlets opened side by side: each
        # inlet's info, opening and first clock offset are round trips (about 0.7 s a
        # stream, one after another)
        with ThreadPoolExecutor(len(self.source_ids)) as pool:
            infos = list(pool.map(_resolve, self.source_ids))
            self.takes = list(pool.map(_Take, infos))
        for take in self.takes:
            take.start()

    def wait_for(self, counts: dict[str, int], timeout: float = HANG_S) -> None:
        """Return once each stream named (by source id) has brought at least its count of
        samples: what was pushed is in, however slowly this machine delivered it."""
        deadline = time.monotonic() + timeout
        takes = {sid: self.takes[self.source_ids.index(sid)] for sid in counts}
        while any(len(takes[sid].stamps) < n for sid, n in counts.items()):
            if time.monotonic() > deadline:
                raise AssertionError("the XDF recorder did not receive everything within "
                                     f"{timeout:g} s: " + ", ".join(
                                         f"{sid} {len(takes[sid].stamps)} of {n}"
                                         for sid, n in counts.items()))
            time.sleep(0.01)

    def stop(self, path: Path) -> Path:
        """Write what came. A stream whose sender is already gone keeps the clock offsets
        measured while it was there, as LabRecorder does (asking it again raised pylsl's
        LostError)."""
        for take in self.takes:
            with contextlib.suppress(pylsl.util.LostError, pylsl.util.TimeoutError):
                take.offsets.append((pylsl.local_clock(), take.inlet.time_correction(5.0)))
            take.stopping.set()
            take.join(10.0)
        out = [b"XDF:", _chunk(1, b'<?xml version="1.0"?><info><version>1.0</version></info>')]
        for sid, take in enumerate(self.takes, start=1):
            head = struct.pack("<I", sid)
            out.append(_chunk(2, head + take.info.as_xml().encode()))
            dtype = _LITTLE_ENDIAN[take.info.channel_format()]
            for start in range(0, len(take.stamps), 100):
                block = b""
                for stamp, sample in zip(take.stamps[start:start + 100],
                                         take.values[start:start + 100], strict=True):
                    block += b"\x08" + struct.pack("<d", stamp)
                    if dtype is None:
                        for text in sample:
                            raw = text.encode()
                            block += _varlen(len(raw)) + raw
                    else:
                        block += np.asarray(sample, dtype=dtype).tobytes()
                count = len(take.stamps[start:start + 100])
                out.append(_chunk(3, head + _varlen(count) + block))
            ahead = self.clocks_ahead.get(self.source_ids[sid - 1], 0.0)
            written = self.written.setdefault(self.source_ids[sid - 1], [])
            for now, value in take.offsets:
                offset = value - ahead
                written.append((now - offset, offset))
                out.append(_chunk(4, head + struct.pack("<dd", now - offset, offset)))
            first = take.stamps[0] if take.stamps else 0.0
            last = take.stamps[-1] if take.stamps else 0.0
            footer = (f'<?xml version="1.0"?><info><first_timestamp>{first!r}</first_timestamp>'
                      f"<last_timestamp>{last!r}</last_timestamp><sample_count>"
                      f"{len(take.stamps)}</sample_count></info>")
            out.append(_chunk(6, head + footer.encode()))
        path.write_bytes(b"".join(out))
        return path
