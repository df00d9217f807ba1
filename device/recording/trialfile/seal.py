"""A trial file's seal: a SHA-256 digest of each of its groups and datasets, written when
the file is closed and again by every addition to it, checked by every reader of what it
reads (docs/data-format.md, "The seal").

Why. The samples' chunks carry Fletcher-32, but the rest carried nothing: text attributes
live in HDF5's global heap, which has no checksum, so one flipped byte changed a trial's
duration (4 → 6 s), its tolerance, its subject code or its status ("bomplete") and the file
loaded as sound. Every value whose change would change a figure or an identity is now in a
digest: the root attributes (status, subject, parameters…), `/parameters`, the channel table
and every channel's units, frame and samples, the events, `/summary`, `/metrics`,
`/assistance`, `/emg`, `/pose`.

What. One digest per object (`part`): a group's is its attributes', a dataset's its
attributes', its type's, its shape's and its values'. The manifest, `{"algorithm":
"sha256", "version": 1, "parts": {path: hex}}`, is the root attribute `seal`, and
`seal_sha256` is the SHA-256 of that text, so a flip in the manifest is found too. Objects
are digested one by one so that a reader checks what it reads (the study table the
metadata, a replay the samples, `rehab emg show` the EMG) and an addition re-seals the group
it writes without reading the rest (`reseal`). A file being recorded cannot be sealed
(HDF5 writes no attribute under SWMR), so its header (everything written before the first
sample: the root attributes, `/parameters`, the channel table, each channel's definition)
has its own digest, `header_sha256`, written before recording starts.

What not. A SHA-256 anyone can recompute: the seal finds damage and edits made without
it (a byte flipped on a disk or in a copy, a value changed in HDFView or h5py), not a
forger who recomputes it. Files travel to researchers who have no key of this
installation, so the digest must be checkable without one (the model files, which decide
what drives the robot, carry a keyed signature instead: app.records.signing).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import struct
from collections.abc import Iterable, Iterator, Mapping

import h5py
import numpy as np

from device.recording.trialfile.verify import Damaged, Inventory, check_heaps, inventory

SEAL = "seal"
SEAL_SHA256 = "seal_sha256"
HEADER_SHA256 = "header_sha256"
ALGORITHM = "sha256"
SEAL_VERSION = 1
NOT_IN_ROOT = frozenset({SEAL, SEAL_SHA256})
"""Root attributes the root's digest leaves out: the seal's own."""
NOT_IN_HEADER = frozenset({SEAL, SEAL_SHA256, HEADER_SHA256, "status", "closed_utc"})
"""Root attributes written after the header (or the header's digest itself)."""
BLOCK_ROWS = 65_536
"""Rows of a dataset read at once to digest it: memory stays bounded for an hour of EMG."""


# -- canonical bytes -----------------------------------------------------------------------------


def dtype_text(dtype: np.dtype) -> str:
    """A type as the seal writes it, the same whatever numpy or h5py version reads it: 'f8',
    'i8', 'u1', 'T' (variable-length text), 'S32' (fixed-length), '{name:type,…}'."""
    if dtype.names:
        return "{" + ",".join(f"{n}:{dtype_text(dtype.fields[n][0])}" for n in dtype.names) + "}"
    if dtype.subdtype is not None:
        base, shape = dtype.subdtype
        return f"{dtype_text(base)}{list(shape)}"
    info = h5py.check_string_dtype(dtype)
    if info is not None:
        return "T" if info.length is None else f"S{info.length}"
    if dtype.kind == "O":
        return "O"
    return f"{dtype.kind}{dtype.itemsize}"


class _Feed:
    """Values into a hash, each tagged and length-prefixed so that no two sequences of
    values give the same bytes."""

    def __init__(self, hash_=None) -> None:
        self.hash = hash_ if hash_ is not None else hashlib.sha256()

    def raw(self, tag: bytes, data: bytes) -> None:
        self.hash.update(tag + struct.pack("<Q", len(data)) + data)

    def text(self, value: str) -> None:
        self.raw(b"T", value.encode("utf-8", "surrogatepass"))

    def value(self, value) -> None:
        if isinstance(value, str):
            self.text(value)
        elif isinstance(value, bytes | np.bytes_):
            self.raw(b"T", bytes(value).rstrip(b"\0"))
        elif isinstance(value, h5py.Empty):
            self.raw(b"E", dtype_text(value.dtype).encode())
        elif isinstance(value, np.ndarray | np.generic):
            self.array(np.asarray(value))
        else:
            self.array(np.asarray(value))

    def array(self, values: np.ndarray) -> None:
        self.raw(b"A", f"{dtype_text(values.dtype)}{list(values.shape)}".encode())
        self.content(values)

    def content(self, values: np.ndarray) -> None:
        """An array's values, in row order: numbers as little-endian bytes, text item by
        item, a table field by field within each row block."""
        if values.dtype.names:
            for name in values.dtype.names:
                self.content(values[name])
        elif values.dtype.kind in "OSU":
            for item in values.ravel():
                self.value(item)
        else:
            little = values.astype(values.dtype.newbyteorder("<"), copy=False)
            self.hash.update(np.ascontiguousarray(little).tobytes())


def running_digests(series: h5py.Group, names: Iterable[str], n_samples: int
                    ) -> dict[str, RunningDigest]:
    """The running digests of channels already in a file (their first `n_samples` rows,
    read block by block): a writer that takes over a dead writer's file
    (TrialFileWriter.resume) goes on from there as if it had appended them itself."""
    digests = {}
    for name in names:
        digest = RunningDigest()
        dataset = series[name]
        for first in range(0, n_samples, BLOCK_ROWS):
            digest.add(dataset[first:min(first + BLOCK_ROWS, n_samples)])
        digests[name] = digest
    return digests


def content_digest(blocks: Iterable[np.ndarray]) -> str:
    """The SHA-256 of a dataset's values given as consecutive blocks of rows (how the writer
    digests samples as it appends them): the same whatever the blocks' sizes, for
    numbers; a table's or text's blocks must be the whole dataset."""
    feed = _Feed()
    for block in blocks:
        feed.content(block)
    return feed.hash.hexdigest()


class RunningDigest:
    """A channel's samples digested as they are appended (TrialFileWriter.append), so the
    writer seals a trial without reading it back."""

    def __init__(self) -> None:
        self._feed = _Feed()

    def add(self, block: np.ndarray) -> None:
        self._feed.content(block)

    def hexdigest(self) -> str:
        return self._feed.hash.hexdigest()


def _attributes(feed: _Feed, values: Mapping, leave_out=frozenset()) -> None:
    for name in sorted(k for k in values if k not in leave_out):
        feed.text(name)
        feed.value(values[name])


def _read_attributes(item) -> dict:
    return {name: item.attrs[name] for name in item.attrs}


def group_digest(path: str, group: h5py.Group, leave_out=frozenset(),
                 attributes: Mapping | None = None) -> str:
    """A group's digest: its attributes (`attributes`: as already read, else read here)."""
    feed = _Feed()
    feed.text("group")
    feed.text(path)
    _attributes(feed, _read_attributes(group) if attributes is None else attributes,
                leave_out)
    return feed.hash.hexdigest()


def dataset_digest(path: str, dataset: h5py.Dataset, values: str | np.ndarray | None = None,
                   attributes: Mapping | None = None) -> str:
    """A dataset's digest; its values read here block by block, or given whole (`values`,
    as a reader already holds them) or as their content_digest (the writer's)."""
    feed = _Feed()
    feed.text("dataset")
    feed.text(path)
    feed.text(dtype_text(dataset.dtype))
    feed.text(str(list(dataset.shape or ())))
    _attributes(feed, _read_attributes(dataset) if attributes is None else attributes)
    if isinstance(values, str):
        content = values
    elif values is not None:
        content = content_digest([values])
    else:
        content = content_digest(_blocks(dataset))
    feed.text(content)
    return feed.hash.hexdigest()


def _blocks(dataset: h5py.Dataset):
    if dataset.shape is None:
        return
    if dataset.ndim == 0:
        yield np.asarray(dataset[()])
        return
    if dataset.dtype.names or dataset.dtype.kind in "OSU":
        yield dataset[()]  # a table or text: small, and digested item by item anyway
        return
    for first in range(0, dataset.shape[0], BLOCK_ROWS):
        yield dataset[first:first + BLOCK_ROWS]


# -- the header, written before recording -----------------------------------------------------


def header_digest(f: h5py.File) -> str:
    """The digest of what a trial file holds before its first sample: the root attributes
    but the status, the parameters' group, the channel table, each channel's type, width,
    units, frame and description, the events' type."""
    feed = _Feed()
    feed.text("header")
    _attributes(feed, _read_attributes(f), NOT_IN_HEADER)
    for path in ("parameters",):
        if isinstance(f.get(path), h5py.Group):
            feed.text(group_digest(f"/{path}", f[path]))
    channels = f.get("channels")
    if isinstance(channels, h5py.Dataset):
        feed.text(dataset_digest("/channels", channels))
    series = f.get("timeseries")
    if isinstance(series, h5py.Group):
        for name in sorted(series):
            dataset = series[name]
            feed.text(name)
            feed.text(dtype_text(dataset.dtype))
            feed.text(str(list((dataset.shape or ())[1:])))
            _attributes(feed, _read_attributes(dataset))
    events = f.get("events")
    if isinstance(events, h5py.Dataset):
        feed.text(dtype_text(events.dtype))
    return feed.hash.hexdigest()


def _fixed(text: str) -> np.bytes_:
    """Text as a fixed-length string attribute, kept in its object's header (checksummed)
    rather than in the global heap, which has no checksum: a reader that still has the
    file open while the writer closes it reads a heap being extended, and the seal's few
    KB are the largest text the close writes."""
    return np.bytes_(text.encode("utf-8"))


def _text_of(value) -> str | None:
    if isinstance(value, bytes | np.bytes_):
        try:
            return bytes(value).decode("utf-8")
        except UnicodeDecodeError:
            return None
    return value if isinstance(value, str) else None


def write_header_seal(f: h5py.File) -> None:
    f.attrs[HEADER_SHA256] = _fixed(header_digest(f))


def check_header(f: h5py.File) -> None:
    stored = _text_of(f.attrs.get(HEADER_SHA256))
    if stored is None:
        raise Damaged("is damaged: its header's digest (header_sha256) is missing, so its "
                      "metadata cannot be verified")
    if header_digest(f) != stored:
        raise Damaged("is damaged: its header (root attributes, parameters or channel "
                      "table) does not match its digest")


# -- the seal ------------------------------------------------------------------------------------


def part_digest(path: str, inventory: Inventory, samples: Mapping[str, str] | None = None
                ) -> str:
    """The digest of one part as it is in the file (`samples`: content digests the writer
    already has, by dataset path)."""
    if path in inventory.groups:
        leave_out = NOT_IN_ROOT if path == "/" else frozenset()
        return group_digest(path, inventory.groups[path], leave_out, inventory.attrs[path])
    return dataset_digest(path, inventory.datasets[path], (samples or {}).get(path),
                          inventory.attrs[path])


def write_seal(f: h5py.File, parts: Mapping[str, str], pending: Iterable[str] = ()) -> None:
    """The seal of `parts`; `pending`: rooms an addition is writing now (see Seal.pending)."""
    document = {"algorithm": ALGORITHM, "version": SEAL_VERSION,
                "parts": dict(sorted(parts.items()))}
    if pending:
        document["pending"] = sorted(set(pending))
    text = json.dumps(document, separators=(",", ":"))
    f.attrs[SEAL] = _fixed(text)
    f.attrs[SEAL_SHA256] = _fixed(hashlib.sha256(text.encode()).hexdigest())


def seal_file(f: h5py.File, inventory: Inventory, samples: Mapping[str, str] | None = None
              ) -> None:
    """Digest every part of a closed file and write the seal (`samples`: the writer's
    running digests of the channels, by dataset path; any other part is read here)."""
    write_seal(f, {path: part_digest(path, inventory, samples)
                   for path in sorted(inventory.paths)})


def seal_at_close(f: h5py.File, n_samples: int, digests: Mapping[str, RunningDigest]) -> None:
    """The writer's last act at close: the seal, the channels' samples from its running
    `digests` (by channel name). A batch a write error left part-written is cut off first:
    only whole batches are in the digests, and a reader trims to them anyway."""
    series = f["timeseries"]
    for name in digests:
        if series[name].shape[0] != n_samples:
            series[name].resize(n_samples, axis=0)
    seal_file(f, inventory(f), {f"/timeseries/{name}": digest.hexdigest()
                                for name, digest in digests.items()})


class Seal:
    """A file's seal as read, checked against its own digest; `check` compares a part.

    `pending`: the rooms ('/metrics') an addition was writing when the seal was last
    written. An addition writes its room in the seal before it changes anything and takes
    it out when it seals again, so a console killed in those milliseconds leaves the room
    marked, not the whole file refused: the parts in a pending room are not compared (the
    reader says so), and the next addition of that room replaces it and seals it."""

    def __init__(self, parts: Mapping[str, str], pending: Iterable[str] = ()) -> None:
        self.parts = dict(parts)
        self.pending = tuple(sorted(set(pending)))

    def is_pending(self, path: str) -> bool:
        return any(in_room(path, room) for room in self.pending)

    @classmethod
    def read(cls, f: h5py.File) -> Seal | None:
        """The file's seal, None when it has none; Damaged when the seal itself is."""
        raw = f.attrs.get(SEAL)
        if raw is None:
            return None
        text, stored = _text_of(raw), _text_of(f.attrs.get(SEAL_SHA256))
        if text is None or stored is None or (
                hashlib.sha256(text.encode("utf-8", "surrogatepass")).hexdigest() != stored):
            raise Damaged("is damaged: its seal (the digest of its content) does not match "
                          "its own SHA-256")
        try:
            document = json.loads(text)
            parts = document["parts"]
            pending = document.get("pending", [])
            ok = (document.get("algorithm") == ALGORITHM
                  and document.get("version") == SEAL_VERSION and isinstance(parts, dict)
                  and all(isinstance(k, str) and isinstance(v, str) for k, v in parts.items())
                  and isinstance(pending, list)
                  and all(isinstance(r, str) and r.startswith("/") and r != "/"
                          for r in pending))
        except (ValueError, KeyError, TypeError, AttributeError):
            ok = False
        if not ok:
            raise Damaged("is damaged: its seal is not one this console writes")
        return cls(parts, pending)

    def check_structure(self, inventory: Inventory) -> None:
        """The file holds exactly the groups and datasets that were sealed."""
        present = {p for p in inventory.paths if not self.is_pending(p)}
        sealed = {p for p in self.parts if not self.is_pending(p)}
        extra = sorted(present - sealed)
        missing = sorted(sealed - present)
        if extra or missing:
            what = "; ".join(filter(None, (
                f"{', '.join(extra[:5])} not sealed" if extra else "",
                f"{', '.join(missing[:5])} missing" if missing else "")))
            raise Damaged(f"is damaged: its groups and datasets are not those it was sealed "
                          f"with ({what})")

    def check(self, path: str, inventory: Inventory, values=None) -> None:
        """Compare one part with its digest (`values`: a dataset's values already read); a
        part in a pending room is not compared."""
        if self.is_pending(path):
            return
        if path in inventory.groups:
            leave_out = NOT_IN_ROOT if path == "/" else frozenset()
            actual = group_digest(path, inventory.groups[path], leave_out,
                                  inventory.attrs[path])
        else:
            actual = dataset_digest(path, inventory.datasets[path], values,
                                    inventory.attrs[path])
        if actual != self.parts.get(path):
            raise Damaged(f"is damaged: {_what(path)} does not match its seal (changed since "
                          "the file was written)")

    def check_room(self, inventory: Inventory, room: str, skip=frozenset()) -> None:
        """Compare every part at or below `room` ('/emg'), but those in `skip` (read and
        compared by the caller)."""
        for path in sorted(inventory.paths):
            if in_room(path, room) and path not in skip:
                self.check(path, inventory)


def in_room(path: str, room: str) -> bool:
    return room == "/" or path == room or path.startswith(room.rstrip("/") + "/")


def _what(path: str) -> str:
    """The part by its path in the file, and what it holds where a path says little."""
    names = {"/": "/ (the root attributes: status, subject, parameters, period…)",
             "/channels": "/channels (the channel table: names, units, frames)",
             "/events": "/events (the events and faults)"}
    return names.get(path, path)


@contextlib.contextmanager
def open_room(path, room: str, skip=frozenset()
              ) -> Iterator[tuple[h5py.File, Inventory, Seal | None] | None]:
    """A trial file opened to read one group beside its samples (`room`: "/emg",
    "/pose"): its heaps and structure checked first and, when it is sealed, the room
    against its seal (but the datasets in `skip`, which the reader checks as it reads
    them). Yields (file, inventory, seal or None), or None when the file has no such
    group. Raises Damaged (one line) for what does not verify."""
    check_heaps(path)
    with h5py.File(path, "r", locking=False) as f:
        found = inventory(f)
        if room not in found.paths:
            yield None
            return
        seal = Seal.read(f)
        if seal is not None:
            seal.check_structure(found)
            seal.check_room(found, room, skip=skip)
        yield f, found, seal
