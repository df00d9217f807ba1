"""A trial file's HDF5 structure checked before anything in it is trusted: what could make
libhdf5 loop for ever, allocate without bound or read another file's data is refused in
one line, before h5py reads a value (docs/data-format.md, "What a reader checks").

* **Global heap collections.** Variable-length strings (every text attribute, the channel
  table) live in the file's global heap, which, unlike every other metadata structure of an
  HDF5 1.10 file, carries no checksum. libhdf5 (2.0.0 included) walks a collection's
  objects by their stored sizes, and one whose size reads 0 (a zeroed disk block) makes
  the walk stand still: every reader of the file hung inside libhdf5, one for 29 minutes.
  `check_heaps` walks each collection the same way first and refuses one that would not
  end. Measured on a 4 s trial (1.4 MB) and a 1 GB file: docs/performance.md.
* **Links and storage.** Every name must be a hard link to an object no other name
  reaches (no soft, external or user-defined link, no alias), no dataset virtual or with
  external storage, no filter but Fletcher-32 (the only one the console writes; a filter
  is a plugin libhdf5 would load), no committed datatype: an external link or a virtual
  dataset in place of `/timeseries/position` pulled another file's samples into an export.
* **Sizes.** No dataset or attribute may claim more bytes than the file holds (plus one
  batch a crashed writer reserved but did not write): `/events` resized to 10⁸ rows in a
  2 MB file made every reader run out of memory. The walk itself is bounded (depth,
  objects, attributes).
"""

from __future__ import annotations

import contextlib
import math
import mmap
import os
import struct
import threading
from dataclasses import dataclass

import h5py
import numpy as np

from device.errors import RecordingError

HEAP_MAGIC = b"GCOL"
HEAP_VERSION = 1
HEAP_HEADER_BYTES = 16
"""Signature, version, 3 reserved bytes, the collection's size (8 bytes)."""
HEAP_OBJECT_HEADER_BYTES = 16
"""An object's index (2), reference count (2), 4 reserved bytes, its size (8)."""

RESERVED_SLACK_BYTES = 16 * 2**20
"""What a dataset may claim beyond the file's size: the rows of one batch that a writer
reserved (an extent) but did not live to write, which read as the fill value and take no
space. A batch is at most a few seconds of samples, well under this."""
MAX_DEPTH = 8
MAX_OBJECTS = 100_000
MAX_ATTRIBUTES = 10_000
"""Bounds of the walk: a trial file has 4 levels, about 60 objects, 30 attributes each."""

FLETCHER32 = h5py.h5z.FILTER_FLETCHER32


class Damaged(RecordingError):
    """A trial file is damaged or not what the console writes; `problem` completes
    "trial file PATH ..." ("is damaged: ...")."""

    def __init__(self, problem: str) -> None:
        self.problem = " ".join(problem.split())  # HDF5's messages carry line breaks
        super().__init__(self.problem)


@dataclass(frozen=True, slots=True)
class Inventory:
    """Every group and dataset of a checked file by its path ('/', '/timeseries/tick')."""

    groups: dict[str, h5py.Group]
    datasets: dict[str, h5py.Dataset]
    file_size: int
    attrs: dict[str, dict]
    """Each object's attributes as h5py read them (after their sizes were checked), read
    once: the seal and the readers use these."""

    @property
    def paths(self) -> set[str]:
        return set(self.groups) | set(self.datasets)


# -- the global heap ---------------------------------------------------------------------------


def check_heaps(path: str | os.PathLike) -> None:
    """Refuse a file with a global heap collection libhdf5 would walk for ever (Damaged).

    Finds each collection by its signature and walks its objects as
    H5HG__cache_heap_deserialize does: the free-space object (index 0) advances by its
    size alone, so a size of 0 stands still. A collection whose stated size runs past the
    end of the file is left to libhdf5, which fails reading it (no loop). The signature
    followed by version 1 in sample data would need a float64 of about 1e-314 or a tick
    past 5e9: not values a trial holds."""
    with open(path, "rb") as stream:
        size = os.fstat(stream.fileno()).st_size
        if size < HEAP_HEADER_BYTES:
            return
        with mmap.mmap(stream.fileno(), 0, access=mmap.ACCESS_READ) as view:
            at = view.find(HEAP_MAGIC)
            while at != -1:
                _check_heap(view, at, size)
                at = view.find(HEAP_MAGIC, at + 1)


def _check_heap(view: mmap.mmap, at: int, file_size: int) -> None:
    if at + HEAP_HEADER_BYTES > file_size or view[at + 4] != HEAP_VERSION:
        return  # libhdf5 refuses another version; no walk happens
    (size,) = struct.unpack_from("<Q", view, at + 8)
    if size < HEAP_HEADER_BYTES or at + size > file_size:
        return  # libhdf5 fails to read it whole: an error, not a loop
    p = HEAP_HEADER_BYTES
    while p < size:
        if p + HEAP_OBJECT_HEADER_BYTES > size:
            return  # the tail too small for an object is free space
        (index,) = struct.unpack_from("<H", view, at + p)
        (object_size,) = struct.unpack_from("<Q", view, at + p + 8)
        # the free space (index 0) states its whole size; an object, its data's
        need = (HEAP_OBJECT_HEADER_BYTES + (object_size + 7) // 8 * 8 if index > 0
                else object_size)
        if need == 0 or need > size - p:
            raise Damaged(
                f"is damaged: its global heap at byte {at} (where text attributes and the "
                f"channel table's text are kept) holds an object of {object_size} bytes at "
                f"offset {p}, which HDF5 would read for ever or past the heap's end")
        p += need


# -- links, storage and sizes ------------------------------------------------------------------


def inventory(f: h5py.File, file_size: int | None = None) -> Inventory:
    """Walk the whole file without following anything but hard links and check every
    object as the module says; Damaged otherwise."""
    if file_size is None:
        file_size = f.id.get_filesize()  # of the open file, whatever its name now
    groups: dict[str, h5py.Group] = {}
    datasets: dict[str, h5py.Dataset] = {}
    attrs: dict[str, dict] = {}
    seen: set[int] = set()
    pending = [("/", f, 0)]
    while pending:
        path, group, depth = pending.pop()
        groups[path] = group
        attrs[path] = _checked_attributes(path, group, file_size)
        names = _names(group)
        if len(groups) + len(datasets) + len(names) > MAX_OBJECTS:
            raise Damaged(f"is damaged: it holds more than {MAX_OBJECTS} objects")
        for name in names:
            child_path = f"{path.rstrip('/')}/{name}"
            item, object_info = _open_child(group, name, child_path)
            if object_info.addr in seen or object_info.rc != 1:
                raise Damaged(f"is not a trial file the console wrote: {child_path} is a "
                              "second name for an object already in the file")
            seen.add(object_info.addr)
            if isinstance(item, h5py.Group):
                if depth + 1 >= MAX_DEPTH:
                    raise Damaged(f"is damaged: {child_path} is nested more than "
                                  f"{MAX_DEPTH} levels deep")
                pending.append((child_path, item, depth + 1))
            elif isinstance(item, h5py.Dataset):
                attrs[child_path] = _check_dataset(child_path, item, file_size)
                datasets[child_path] = item
            else:
                raise Damaged(f"is not a trial file the console wrote: {child_path} is a "
                              "named datatype")
    return Inventory(groups, datasets, file_size, attrs)


def _open_child(group: h5py.Group, name: str, path: str):
    """The object a hard link names and its HDF5 info; Damaged for any other link or an
    object HDF5 cannot open."""
    try:
        info = group.id.links.get_info(name.encode("utf-8"))
    except (OSError, RuntimeError, ValueError, KeyError) as exc:
        raise Damaged(f"is damaged: the link {path} cannot be read ({exc})") from exc
    if info.type != h5py.h5l.TYPE_HARD:
        raise Damaged(f"is not a trial file the console wrote: {path} is "
                      f"{_link_kind(group, name, info.type)}, and a trial file holds its own "
                      "data only")
    try:
        item = group.get(name)
        if item is None:
            raise KeyError(name)
        return item, h5py.h5o.get_info(item.id)
    except (OSError, RuntimeError, ValueError, KeyError, TypeError) as exc:
        raise Damaged(f"is damaged: {path} cannot be opened ({exc})") from exc


def _names(group: h5py.Group) -> list[str]:
    try:
        return list(group.keys())
    except (OSError, RuntimeError, ValueError, UnicodeDecodeError) as exc:
        raise Damaged(f"is damaged: the names in {group.name} cannot be read ({exc})") from exc


def _link_kind(group: h5py.Group, name: str, kind: int) -> str:
    try:
        link = group.get(name, getlink=True)
    except (OSError, RuntimeError, ValueError, KeyError):
        link = None
    if isinstance(link, h5py.ExternalLink):
        return f"an external link to {link.path} in the file {link.filename!r}"
    if isinstance(link, h5py.SoftLink):
        return f"a soft link to {link.path}"
    return f"a link of HDF5 type {kind}"


def _check_dataset(path: str, dataset: h5py.Dataset, file_size: int) -> dict:
    try:
        plist = dataset.id.get_create_plist()
        layout, external = plist.get_layout(), plist.get_external_count()
        filters = [plist.get_filter(i)[0] for i in range(plist.get_nfilters())]
        shape, itemsize = dataset.shape, dataset.dtype.itemsize
    except (OSError, RuntimeError, ValueError, TypeError) as exc:
        raise Damaged(f"is damaged: the layout of {path} cannot be read ({exc})") from exc
    if layout == h5py.h5d.VIRTUAL:
        raise Damaged(f"is not a trial file the console wrote: {path} is a virtual dataset "
                      "(its data would come from other files)")
    if external:
        raise Damaged(f"is not a trial file the console wrote: {path} keeps its data in "
                      "another file (external storage)")
    for code in filters:
        if code != FLETCHER32:
            raise Damaged(f"is not a trial file the console wrote: {path} is stored through "
                          f"HDF5 filter {code}; the console writes Fletcher-32 checksums only")
    values = _checked_attributes(path, dataset, file_size)
    if shape is None:
        return values  # an empty (null) dataspace holds nothing
    claimed = math.prod(shape) * itemsize
    if claimed > file_size + RESERVED_SLACK_BYTES:
        raise Damaged(f"is damaged: {path} claims {shape} values ({_bytes(claimed)}) in a "
                      f"file of {_bytes(file_size)}")
    return values


def _checked_attributes(path: str, item, file_size: int) -> dict:
    """The object's attributes, each read only once its claimed size is known to fit."""
    try:
        names = list(item.attrs)  # a File's opens its root group first: KeyError then
    except (OSError, RuntimeError, ValueError, UnicodeDecodeError, KeyError) as exc:
        raise Damaged(f"is damaged: the attribute names of {path} cannot be read "
                      f"({exc})") from exc
    if len(names) > MAX_ATTRIBUTES:
        raise Damaged(f"is damaged: {path} has {len(names)} attributes")
    values = {}
    for name in names:
        try:
            attribute = h5py.h5a.open(item.id, name.encode("utf-8"))
            shape, dtype = attribute.shape, attribute.dtype
            itemsize = dtype.itemsize
        except (OSError, RuntimeError, ValueError, TypeError) as exc:
            raise Damaged(f"is damaged: the attribute {name} of {path} cannot be read "
                          f"({exc})") from exc
        claimed = math.prod(shape or ()) * itemsize
        if claimed > file_size + RESERVED_SLACK_BYTES:
            raise Damaged(f"is damaged: the attribute {name} of {path} claims {shape} values "
                          f"({_bytes(claimed)}) in a file of {_bytes(file_size)}")
        try:
            values[name] = _value(attribute, shape, dtype)
        except (OSError, RuntimeError, ValueError, TypeError, KeyError) as exc:
            raise Damaged(f"is damaged: the attribute {name} of {path} cannot be read "
                          f"({exc})") from exc
    return values


def _value(attribute, shape, dtype) -> object:
    """An open attribute's value as h5py's `attrs[name]` gives it (h5py._hl.attrs), read
    through the id already open: h5py's way opens it again, and a trial file has about 200
    attributes, read on every load. `shape` and `dtype` are the attribute's, as read once
    by the caller (each read translates the file's type again: a fifth of a load)."""
    if shape is None:
        return h5py.Empty(dtype)
    memory_type = h5py.h5t.py_create(dtype)
    if dtype.subdtype is not None:  # numpy has no top-level array type: (5,) of (3,)f
        dtype, inner = dtype.subdtype
        shape = shape + inner
    values = np.zeros(shape, dtype=dtype, order="C")
    attribute.read(values, mtype=memory_type)
    text = h5py.check_string_dtype(dtype)
    if text is not None and text.length is None:
        values = np.array([b.decode("utf-8", "surrogateescape") for b in values.flat],
                          dtype=dtype).reshape(values.shape)
    return values[()] if values.ndim == 0 else values


def _bytes(n: int) -> str:
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{n} bytes"


_LOCKS: dict[str, threading.RLock] = {}
_LOCKS_GUARD = threading.Lock()


@contextlib.contextmanager
def held(path: str | os.PathLike):
    """This process's lock of one trial file, held by every reader and every addition for as
    long as it has the file open: HDF5 lets a thread open for reading a file another thread
    has open for writing, and shares one file between them; reads in one thread while an
    addition wrote in another crashed the process (a segfault in libhdf5, reproduced with
    one thread storing metrics and two reading). Other processes are kept out by HDF5's own
    flags (a file open for writing refuses a reader)."""
    key = os.path.realpath(path)
    with _LOCKS_GUARD:
        lock = _LOCKS.setdefault(key, threading.RLock())
    with lock:
        yield
