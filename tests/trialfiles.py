"""Trial files as the tests need them beside what the writer makes: edited by hand and
sealed again (a file as the console would have written it, not damage), left as a crash
leaves them, or as an older console wrote them (docs/data-format.md, "The seal"); and
records to write whose values another process can rebuild (`ramp_records`)."""

from __future__ import annotations

import contextlib

import h5py
import numpy as np

SEAL, SEAL_SHA256, HEADER_SHA256 = "seal", "seal_sha256", "header_sha256"
"""The seal's root attributes (device.recording.trialfile.seal)."""


def flip_last_byte(path) -> None:
    """One bit of a file's last byte flipped: a trial file changed after it was finished
    (or its copy damaged in a trial store), whose SHA-256 is no longer the one recorded."""
    with open(path, "r+b") as file:
        file.seek(-1, 2)
        last = file.read(1)
        file.seek(-1, 2)
        file.write(bytes([last[0] ^ 1]))


@contextlib.contextmanager
def edited(path):
    """h5py's file opened to change it, sealed again on leaving (when it was sealed): a
    fabrication of a file the console could have written (a live trial's summary, another
    muscle under an electrode), which a reader must then accept."""
    from device.recording.trialfile.seal import seal_file
    from device.recording.trialfile.verify import inventory

    with h5py.File(path, "r+", locking=False) as f:
        yield f
        if SEAL in f.attrs:
            seal_file(f, inventory(f))


def as_crashed(path):
    """The file as its recorder leaves it when it dies before closing: status
    'recording', the header's digest, no seal."""
    with h5py.File(path, "r+", locking=False) as f:
        for name in (SEAL, SEAL_SHA256):
            if name in f.attrs:
                del f.attrs[name]
        f.attrs["status"] = "recording"
    return path


def as_format_1(path):
    """The file as a console before the seal (format version 1) wrote it: the same layout
    without the seal's attributes."""
    with h5py.File(path, "r+", locking=False) as f:
        for name in (SEAL, SEAL_SHA256, HEADER_SHA256):
            if name in f.attrs:
                del f.attrs[name]
        f.attrs["format_version"] = np.int64(1)
    return path


def ramp_records(start, n, dtype, *, valid=False):
    """Records whose every value follows from its tick, so another process can rebuild them.
    `valid`: the code fields hold codes and the assistance level lies in 0…1, as a reader
    checks them (app.trials.checks). Self-contained: the writer scripts the tests run in
    another process take its source (inspect.getsource)."""
    import numpy as np

    records = np.zeros(n, dtype=dtype)
    tick = np.arange(start, start + n)
    for k, name in enumerate(dtype.names):
        field = records[name]
        column = (tick + k) % 200 if field.dtype.kind in "iu" else tick * 1e-3 + k
        records[name] = column.reshape((n,) + (1,) * (field.ndim - 1))
    if valid:
        from app.trials.checks import CODES

        for name, allowed in CODES.items():  # codes hold codes
            if name in dtype.names:
                records[name] = np.asarray(sorted(allowed))[tick % len(allowed)]
        if "assistance_level" in dtype.names:
            records["assistance_level"] = (tick % 101) / 100
    records["tick"] = tick
    return records
