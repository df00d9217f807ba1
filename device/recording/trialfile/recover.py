"""A trial file whose writer died with it open: its "open for writing" flags cleared, as
`h5clear -s` does, so that HDF5 opens it again (docs/data-format.md, Crash safety).

HDF5 1.10 files (superblock version 2 or 3, what the console writes: `LIBVER`) carry in
their superblock a byte of file-consistency flags: bit 0 "open for writing", bit 2 "open
for SWMR writing". A writer sets them as it opens the file and clears them as it closes
it. A writer that dies in between leaves them set, and HDF5 then refuses the file: an
SWMR reader opens a file flagged for SWMR writing, but not one flagged for plain writing
("file is not already open for SWMR writing"), which a writer killed while it added the
status, the metrics or EMG leaves behind; and no writer opens either. Clearing them is
safe once the writer is dead: every object in the file was written before the metadata
that points to it (SWMR's order), and the reader checks what it reads.

The superblock (HDF5 File Format Specification, version 3.0, section II.A, "Version 2
and 3"): signature (8 bytes), version (1), size of offsets (1), size of lengths (1),
flags (1), base address, superblock-extension address, end-of-file address, root-group
object-header address (each `size of offsets` bytes, little-endian), then a Jenkins
lookup3 checksum (4 bytes) of all that precedes it. The superblock is at 0 or at 512,
1024, 2048… (after a user block).
"""

from __future__ import annotations

import os
from pathlib import Path

from device.errors import RecordingError

SIGNATURE = b"\x89HDF\r\n\x1a\n"
WRITE_FLAGS = 0x01 | 0x04
"""File-consistency flags of a writer: "open for writing", "open for SWMR writing"."""
_MASK = 0xFFFFFFFF


def lookup3(data: bytes, initval: int = 0) -> int:
    """Bob Jenkins' lookup3 `hashlittle` (2006), byte by byte as HDF5 computes its
    metadata checksums (H5_checksum_lookup3)."""

    def rot(x: int, k: int) -> int:
        return ((x << k) | (x >> (32 - k))) & _MASK

    length = len(data)
    a = b = c = (0xDEADBEEF + length + initval) & _MASK
    i = 0
    while length > 12:
        a = (a + int.from_bytes(data[i:i + 4], "little")) & _MASK
        b = (b + int.from_bytes(data[i + 4:i + 8], "little")) & _MASK
        c = (c + int.from_bytes(data[i + 8:i + 12], "little")) & _MASK
        # mix(a, b, c)
        a = (a - c) & _MASK
        a ^= rot(c, 4)
        c = (c + b) & _MASK
        b = (b - a) & _MASK
        b ^= rot(a, 6)
        a = (a + c) & _MASK
        c = (c - b) & _MASK
        c ^= rot(b, 8)
        b = (b + a) & _MASK
        a = (a - c) & _MASK
        a ^= rot(c, 16)
        c = (c + b) & _MASK
        b = (b - a) & _MASK
        b ^= rot(a, 19)
        a = (a + c) & _MASK
        c = (c - b) & _MASK
        c ^= rot(b, 4)
        b = (b + a) & _MASK
        length -= 12
        i += 12
    if length == 0:
        return c
    tail = data[i:i + length] + bytes(12 - length)
    a = (a + int.from_bytes(tail[0:4], "little")) & _MASK
    b = (b + int.from_bytes(tail[4:8], "little")) & _MASK
    c = (c + int.from_bytes(tail[8:12], "little")) & _MASK
    # final(a, b, c)
    c ^= b
    c = (c - rot(b, 14)) & _MASK
    a ^= c
    a = (a - rot(c, 11)) & _MASK
    b ^= a
    b = (b - rot(a, 25)) & _MASK
    c ^= b
    c = (c - rot(b, 16)) & _MASK
    a ^= c
    a = (a - rot(c, 4)) & _MASK
    b ^= a
    b = (b - rot(a, 14)) & _MASK
    c ^= b
    c = (c - rot(b, 24)) & _MASK
    return c


def _superblock(fd: int, path: Path) -> tuple[int, bytes]:
    """(offset, bytes) of the file's version 2/3 superblock, its checksum verified."""
    offset = 0
    size = os.fstat(fd).st_size
    while offset + 12 <= size:
        head = os.pread(fd, 12, offset)
        if head[:8] == SIGNATURE:
            break
        offset = 512 if offset == 0 else offset * 2
    else:
        raise RecordingError(f"{path.name} has no HDF5 signature: it is not a trial file")
    version, offsets_size = head[8], head[9]
    if version not in (2, 3):
        raise RecordingError(f"{path.name} has an HDF5 superblock of version {version}, which "
                             "keeps no open-for-writing flags: nothing to clear")
    if offsets_size not in (2, 4, 8, 16):
        raise RecordingError(f"{path.name}: its HDF5 superblock is damaged (offsets of "
                             f"{offsets_size} bytes)")
    length = 12 + 4 * offsets_size
    block = os.pread(fd, length + 4, offset)
    if len(block) < length + 4 or lookup3(block[:length]) != int.from_bytes(
            block[length:], "little"):
        raise RecordingError(f"{path.name}: its HDF5 superblock is damaged (its checksum does "
                             "not match); restore the file from a backup")
    return offset, block


def open_flags(path: str | os.PathLike) -> int:
    """The superblock's file-consistency flags (0 for a file closed by its writer)."""
    path = Path(path)
    fd = os.open(path, os.O_RDONLY)
    try:
        return _superblock(fd, path)[1][11]
    finally:
        os.close(fd)


def clear_open_flags(path: str | os.PathLike) -> bool:
    """Clear the flags a dead writer left set (`h5clear -s`); whether there were any. Only
    for a file whose writer is known to be dead: a live one would set them again at its
    next flush, and two writers would damage the file. Also makes the file as long as its
    superblock says it is (the end-of-file address), as a writer's last allocation may
    not have reached the disk: the missing end reads as zeros, which no checked object
    accepts. RecordingError when the file is not an HDF5 1.10 file or its superblock is
    damaged."""
    path = Path(path)
    fd = os.open(path, os.O_RDWR)
    try:
        offset, block = _superblock(fd, path)
        length = len(block) - 4
        flags = block[11]
        size = block[9]
        end_at = 12 + 2 * size
        end_of_file = int.from_bytes(block[end_at:end_at + size], "little") + offset
        grown = False
        if end_of_file > os.fstat(fd).st_size:
            os.ftruncate(fd, end_of_file)  # a hole: no disk space taken
            grown = True
        if not flags & WRITE_FLAGS:
            return grown
        fixed = bytearray(block[:length])
        fixed[11] = flags & ~WRITE_FLAGS & 0xFF
        os.pwrite(fd, bytes(fixed) + lookup3(bytes(fixed)).to_bytes(4, "little"), offset)
        os.fsync(fd)
        return True
    finally:
        os.close(fd)
