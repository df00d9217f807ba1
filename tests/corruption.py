"""Corrupted copies of every file type the console reads, each read by the console's own
readers in a worker process with a time limit per file, and the outcome judged against
the original (issue 28, "What the tests must prove": the corruption test). Used by
tests/test_corruption.py (a sample, in the suite) and bench/corruption.py (≥ 10³ files).

Outcomes of one corrupted file:

* `refused`: every reader that read the damage refused it in one line, with the console's
  own error (what the command line prints with exit 2); the others read what the original
  holds.
* `same`: every reader read exactly what the original holds (the bytes changed were not
  data: padding, free space, a comment).
* `noted`: read with different data, and a note that says so (a crashed file trimmed…).
* `silent`: read with different data and nothing said. For a format with a checksum or a
  signature (trial files, model files) that is a failure. A format without one (CSV,
  JSON settings, SQLite, video pixels) cannot tell a changed digit from the value
  written: those are counted apart, as `unchecked`.
* `crash`: an exception that is not the console's one-line refusal (a traceback).
* `hang`: no answer within the time limit; the worker is killed and another started.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import json
import os
import random
import select
import shutil
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
CHECKED_KINDS = ("trial", "model", "emg-model", "registry")
"""Formats with a checksum or a signature (the registry's rows are sealed since schema v6,
app.records.registry.seals): a silent load of them is a failure."""
OUTCOMES = ("refused", "same", "noted", "silent", "unchecked", "crash", "hang")


@dataclass(frozen=True)
class Case:
    kind: str
    how: str
    path: str
    original: str


@dataclass(frozen=True)
class Result:
    case: Case
    outcome: str
    detail: str


# -- fingerprints of what the readers return -------------------------------------------------


def fingerprint(value) -> str:
    """A SHA-256 of a reader's result, the same for equal data (NaN equal to NaN)."""
    h = hashlib.sha256()
    _feed(h, value)
    return h.hexdigest()


def _feed(h, value) -> None:
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        value = {f.name: getattr(value, f.name) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        h.update(b"{")
        for key in sorted(value, key=str):
            if key in ("path", "notes", "file"):
                continue  # where the copy is and what was said are not the data
            h.update(repr(key).encode())
            _feed(h, value[key])
        h.update(b"}")
    elif isinstance(value, list | tuple):
        h.update(b"[")
        for item in value:
            _feed(h, item)
        h.update(b"]")
    elif isinstance(value, np.ndarray):
        h.update(f"a{value.dtype.str}{value.shape}".encode())
        if value.dtype.kind == "O" or value.dtype.names:
            for item in value.ravel().tolist():
                _feed(h, item)
        else:
            h.update(np.ascontiguousarray(value).tobytes())
    elif isinstance(value, np.generic):
        _feed(h, value.item())
    elif hasattr(value, "to_dict") and callable(value.to_dict):
        _feed(h, value.to_dict())
    else:
        h.update(repr(value).encode())


# -- the readers, as the worker runs them ---------------------------------------------------


def _read_trial(path: str) -> tuple[list, list[str]]:
    """Every reader of a trial file: the console's, the researcher's loader and study row,
    the groups of a .mat export, the EMG (`rehab emg show`'s), the pose."""
    from app.emg.session import trial_envelopes
    from app.exports.loader import read_info
    from app.pose.store import read_pose
    from app.trials.reader import read_groups, read_trial
    from device.recording.emgfile import read_emg

    parts, notes = [], []
    trial = read_trial(path)
    parts.append(trial)
    notes += trial.notes
    parts.append(read_info(path).row())
    parts.append(read_groups(path))
    emg = read_emg(path)
    parts.append(emg)
    if emg is not None and emg.mvc:
        parts.append(trial_envelopes(path))
    parts.append(read_pose(path))
    return parts, notes


def _read_model(path: str):
    from app.learning.modelfile import read_model

    m = read_model(path)
    return [m.spec, m.params, m.data, m.content_sha256], []


def _read_emg_model(path: str):
    from app.emg.modelfile import read_emg_model

    m = read_emg_model(path)
    return [m.model.to_dict(), m.muscles, m.settings, m.validations, m.latency_s,
            m.tolerance_rad, m.content_sha256], []


def _read_emg_csv(path: str):
    from device.emg.files import read_emg_file

    d = read_emg_file(path)
    return [d.names, d.rate_hz, d.t_s, d.samples, d.source], list(d.notes)


def _read_settings(path: str):
    """The settings as the console starts with them: load_settings, then the data folder
    (locate_data_dir refuses to guess one when the file that named it is unreadable). A
    file the console set aside (renamed settings.json.corrupt-<time>, said in its log) is
    read with that note: the defaults, or only the data folder it could read back."""
    from app.records.datadir import locate_data_dir
    from app.records.settings import load_settings

    settings = load_settings(path)
    folder = locate_data_dir(settings, environ={})
    aside = sorted(p.name for p in Path(path).parent.glob(f"{Path(path).name}.corrupt-*"))
    notes = [f"set aside as {aside[-1].split('.', 1)[1]}"] if aside else []
    return [settings.to_json(), str(folder.root)], notes


def _read_registry(path: str):
    """`path` is a data folder holding registry.sqlite3."""
    from app.records.registry import Registry

    registry = Registry(Path(path), create=False)
    patients = registry.patients()
    return [patients, [registry.trials_for_patient(p.code) for p in patients]], []


def _read_video(path: str):
    from device.camera.video import frames, open_video

    info = open_video(path)
    pictures = [hashlib.sha256(image.tobytes()).hexdigest() for _, image in frames(info)]
    return [info.frames, info.width, info.height, info.fps, info.stamps_s, pictures], []


READERS = {"trial": _read_trial, "model": _read_model, "emg-model": _read_emg_model,
           "emg-csv": _read_emg_csv, "mvc-csv": _read_emg_csv, "settings": _read_settings,
           "registry": _read_registry, "video": _read_video, "timestamps": _read_video}


def read_once(kind: str, path: str) -> dict:
    """Run the readers of `kind` on `path`: {"status": "read", "fingerprint", "notes"},
    {"status": "refused", "message"} or {"status": "crash", "message"}."""
    from app.cli.common import CommandError
    from app.errors import AppError
    from core.errors import CoreError
    from device.errors import DeviceError

    try:
        parts, notes = READERS[kind](path)
    except (AppError, DeviceError, CoreError, CommandError) as exc:
        text = str(exc)
        if "\n" in text or not text.strip():
            return {"status": "crash", "message": f"refusal not one line: {text[:300]!r}"}
        return {"status": "refused", "message": text[:1000]}
    except BaseException as exc:
        return {"status": "crash", "message": f"{type(exc).__name__}: {str(exc)[:300]}"}
    return {"status": "read", "fingerprint": fingerprint(parts), "notes": sorted(notes)}


def worker() -> None:
    """Read one JSON request a line ({"kind", "path"}), answer one JSON line."""
    import warnings

    warnings.simplefilter("ignore")
    for line in sys.stdin:
        request = json.loads(line)
        answer = read_once(request["kind"], request["path"])
        sys.stdout.write(json.dumps(answer) + "\n")
        sys.stdout.flush()


class Worker:
    """The readers in a process of their own: a hang is killed, not waited for."""

    def __init__(self, env: dict | None = None) -> None:
        self.env = env
        self.process = None

    def _start(self) -> None:
        self.process = subprocess.Popen(
            [sys.executable, "-c", "from tests.corruption import worker; worker()"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            text=True, cwd=ROOT, env=self.env)

    def ask(self, kind: str, path: str, timeout_s: float) -> dict | None:
        """The worker's answer, or None when it gave none within `timeout_s` (then killed)."""
        if self.process is None or self.process.poll() is not None:
            self._start()
            timeout_s += 30.0  # the first request also pays for the imports
        self.process.stdin.write(json.dumps({"kind": kind, "path": path}) + "\n")
        self.process.stdin.flush()
        ready, _, _ = select.select([self.process.stdout], [], [], timeout_s)
        line = self.process.stdout.readline() if ready else ""
        if not line:
            self.close()
            return None
        return json.loads(line)

    def close(self) -> None:
        if self.process is not None:
            with contextlib.suppress(OSError):
                self.process.kill()
            self.process.wait()
            for stream in (self.process.stdin, self.process.stdout):
                with contextlib.suppress(OSError):
                    stream.close()
            self.process = None


def judge(case: Case, original: dict, answer: dict | None) -> Result:
    if answer is None:
        return Result(case, "hang", "no answer within the time limit")
    if answer["status"] == "crash":
        return Result(case, "crash", answer["message"])
    if answer["status"] == "refused":
        return Result(case, "refused", answer["message"])
    if original.get("status") == "read" and answer["fingerprint"] == original["fingerprint"]:
        return Result(case, "same", "")
    if answer["notes"] != original.get("notes", []):
        return Result(case, "noted", "; ".join(answer["notes"])[:300])
    outcome = "silent" if case.kind in CHECKED_KINDS else "unchecked"
    return Result(case, outcome, "read with other data and nothing said")


def run(cases: list[Case], *, timeout_s: float = 20.0, env: dict | None = None,
        progress=None) -> list[Result]:
    """Every case read by the readers of its kind; the originals first, for comparison."""
    worker_ = Worker(env)
    originals: dict[tuple[str, str], dict] = {}
    results = []
    try:
        for i, case in enumerate(cases):
            key = (case.kind, case.original)
            if key not in originals:
                originals[key] = worker_.ask(case.kind, case.original, timeout_s) or {}
                if originals[key].get("status") != "read":
                    raise RuntimeError(f"the original {case.original} does not read: "
                                       f"{originals[key]}")
            results.append(judge(case, originals[key], worker_.ask(case.kind, case.path,
                                                                    timeout_s)))
            if progress is not None:
                progress(i + 1, len(cases))
    finally:
        worker_.close()
    return results


def unnamed(results: list[Result]) -> list[Result]:
    """The refusals that do not name the file they refuse (its name without the suffixes,
    which every copy's name begins with: `c00012` of c00012.h5, of the registry folder
    c00012/, of settings c00012.json set aside as c00012.json.corrupt-<time>; `v00003` of
    a video's timestamps v00003.avi.timestamps.csv)."""
    return [r for r in results if r.outcome == "refused"
            and Path(r.case.path).name.split(".")[0] not in r.detail]


def tally(results: list[Result]) -> dict[str, dict[str, int]]:
    table: dict[str, dict[str, int]] = {}
    for r in results:
        row = table.setdefault(r.case.kind, dict.fromkeys(OUTCOMES, 0))
        row[r.outcome] += 1
    return table


# -- corruptions -----------------------------------------------------------------------------


class Corrupter:
    """Writes corrupted copies of originals into `folder`, one file (or video pair) a case."""

    def __init__(self, folder: Path, seed: int) -> None:
        self.folder = Path(folder)
        self.folder.mkdir(parents=True, exist_ok=True)
        self.rng = random.Random(seed)
        self.count = 0

    def _copy(self, original: Path) -> Path:
        """A copy of the original: a file, or for a registry (a data folder) the folder with
        a copy of its registry.sqlite3; the file to damage is `_file_of` it."""
        self.count += 1
        if original.is_dir():
            target = self.folder / f"c{self.count:05d}"
            target.mkdir()
            shutil.copyfile(_file_of(original), _file_of(target))
            return target
        target = self.folder / f"c{self.count:05d}{''.join(original.suffixes)}"
        shutil.copyfile(original, target)
        return target

    def bytes_case(self, kind: str, original: Path, how: str, change) -> Case | None:
        """A copy whose bytes `change(bytearray) -> str | None` alters (None: no case)."""
        before = _file_of(original).read_bytes()
        data = bytearray(before)
        said = change(data)
        if said is None or bytes(data) == before:
            return None
        target = self._copy(original)
        _file_of(target).write_bytes(bytes(data))
        return Case(kind, f"{how} {said}", str(target), str(original))

    def video_case(self, kind: str, original: Path, how: str, change) -> Case | None:
        """A copy of a video with its timestamps, the video (`kind` video) or the
        timestamps (`timestamps`) changed."""
        from device.camera.capture import timestamps_path

        self.count += 1
        target = self.folder / f"v{self.count:05d}{original.suffix}"
        shutil.copyfile(original, target)
        shutil.copyfile(timestamps_path(original), timestamps_path(target))
        changed = target if kind == "video" else timestamps_path(target)
        data = bytearray(changed.read_bytes())
        said = change(data)
        if said is None or bytes(data) == changed.read_bytes():
            return None
        changed.write_bytes(bytes(data))
        return Case(kind, f"{how} {said}", str(target), str(original))

    # byte-level damage ----------------------------------------------------------------------

    def flip(self, head: int | None = None):
        def change(data: bytearray):
            end = len(data) if head is None else min(head, len(data))
            at = self.rng.randrange(end)
            bit = self.rng.randrange(8)
            data[at] ^= 1 << bit
            return f"bit {bit} of byte {at}"
        return change

    def byte(self, head: int | None = None):
        def change(data: bytearray):
            end = len(data) if head is None else min(head, len(data))
            at = self.rng.randrange(end)
            data[at] = self.rng.randrange(256)
            return f"byte {at} set to {data[at]}"
        return change

    def zero_block(self, size: int = 4096):
        def change(data: bytearray):
            blocks = max(1, len(data) // size)
            k = self.rng.randrange(blocks)
            data[k * size:(k + 1) * size] = bytes(len(data[k * size:(k + 1) * size]))
            return f"block {k} of {size} bytes zeroed"
        return change

    def truncate(self):
        def change(data: bytearray):
            at = self.rng.randrange(len(data))
            del data[at:]
            return f"cut at {at} bytes"
        return change

    def damage(self, kind: str, original: Path, n: int, head: int | None = None,
               video: bool = False) -> list[Case]:
        """`n` cases of random byte-level damage: flips (half in the first `head` bytes when
        given), set bytes, zeroed blocks, truncations."""
        makers = [("flip", lambda: self.flip()), ("flip", lambda: self.flip(head)),
                  ("byte", lambda: self.byte(head)), ("zero", lambda: self.zero_block()),
                  ("truncate", lambda: self.truncate())]
        cases = []
        attempts = 0
        while len(cases) < n and attempts < 20 * n:
            attempts += 1
            how, make = makers[self.rng.randrange(len(makers))]
            make_case = self.video_case if video else self.bytes_case
            case = make_case(kind, original, how, make())
            if case is not None:
                cases.append(case)
        return cases


def _file_of(path: Path) -> Path:
    return path / "registry.sqlite3" if path.is_dir() else path


# -- h5py edits of a trial file --------------------------------------------------------------


def _edit_trial(path: Path, edit: str, reseal: bool) -> None:
    import h5py

    from device.recording.trialfile.seal import seal_file
    from device.recording.trialfile.verify import inventory

    with h5py.File(path, "r+", locking=False) as f:
        TRIAL_EDITS[edit](f, path)
        if reseal and "seal" in f.attrs:
            f.flush()
            seal_file(f, inventory(f))


def _replace(f, name: str, data) -> None:
    import h5py

    attrs = dict(f[name].attrs)
    del f[name]
    parent, _, leaf = name.rpartition("/")
    dataset = f[parent or "/"].create_dataset(leaf, data=data)
    for key, value in attrs.items():
        dataset.attrs[key] = value
    del h5py  # only for the type checker


def _json_edit(f, key: str, change) -> None:
    value = json.loads(f.attrs[key])
    change(value)
    f.attrs[key] = json.dumps(value)


def _external(f, path: Path) -> None:
    import h5py

    other = path.with_name(path.stem + "-other.h5")
    with h5py.File(other, "w") as g:
        g["position"] = np.zeros((f["timeseries/position"].shape[0], 2))
    del f["timeseries/position"]
    f["timeseries/position"] = h5py.ExternalLink(other.name, "/position")


def _virtual(f, path: Path) -> None:
    import h5py

    other = path.with_name(path.stem + "-virtual.h5")
    shape = f["timeseries/position"].shape
    with h5py.File(other, "w") as g:
        g["position"] = np.ones(shape)
    layout = h5py.VirtualLayout(shape=shape, dtype="f8")
    layout[:] = h5py.VirtualSource(other.name, "position", shape=shape)
    del f["timeseries/position"]
    f["timeseries"].create_virtual_dataset("position", layout, fillvalue=np.nan)


def _soft(f, path: Path) -> None:
    import h5py

    del f["timeseries/position"]
    f["timeseries/position"] = h5py.SoftLink("/timeseries/position_desired")


def _hard_alias(f, path: Path) -> None:
    del f["timeseries/position"]
    f["timeseries/position"] = f["timeseries/position_desired"]


def _emg_columns(f, path: Path) -> None:
    samples = f["emg/samples"][()]
    _replace(f, "emg/samples", np.concatenate([samples, samples[:, :2]], axis=1))


def _emg_time(f, change) -> None:
    t = f["emg/time"][()]
    change(t)
    _replace(f, "emg/time", t)


def _mvc_flags_text(f, path: Path) -> None:
    group = f["emg/mvc"][next(iter(f["emg/mvc"]))]
    group.attrs["flags"] = "saturated"


def _channels_units(f, path: Path) -> None:
    table = f["channels"][()]
    table[0]["units"] = b"mm"
    f["channels"][...] = table


def _code(name: str, value: int):
    def edit(f, path):
        values = f[f"timeseries/{name}"][()]
        values[len(values) // 2] = value
        f[f"timeseries/{name}"][...] = values
    return edit


def _sample(f, path: Path) -> None:
    values = f["timeseries/position"][()]
    values[len(values) // 3, 0] += 0.01
    f["timeseries/position"][...] = values


TRIAL_EDITS = {
    "status bomplete": lambda f, p: f.attrs.__setitem__("status", "bomplete"),
    "status complete→faulted": lambda f, p: f.attrs.__setitem__("status", "faulted"),
    "subject code": lambda f, p: _json_edit(f, "subject", lambda v: v.__setitem__("code",
                                                                                "PY0739Q")),
    "duration 4→6 s": lambda f, p: _json_edit(
        f, "parameters", lambda v: v.__setitem__("duration_s", v["duration_s"] * 1.5)),
    "tolerance": lambda f, p: _json_edit(
        f, "parameters", lambda v: v.__setitem__("tolerance_rad", 0.149)),
    "parameters null": lambda f, p: f.attrs.__setitem__("parameters", "null"),
    "period": lambda f, p: f.attrs.__setitem__("sample_period_s", 0.004),
    "channel units": _channels_units,
    "dataset units": lambda f, p: f["timeseries/force"].attrs.__setitem__("units", "kN"),
    "metric": lambda f, p: f["metrics"].attrs.__setitem__(
        next(iter(f["metrics"].attrs)), 1.0),
    "summary": lambda f, p: f["summary"].attrs.__setitem__("n_events", 99),
    "event message": lambda f, p: f["events"].__setitem__(
        0, (0.0, 0, b"start", b"edited", b"{}")),
    "sample value": _sample,
    "position int32": lambda f, p: _replace(f, "timeseries/position",
                                            f["timeseries/position"][()].astype("i4")),
    "position (N,3)": lambda f, p: _replace(f, "timeseries/position", np.zeros(
        (f["timeseries/position"].shape[0], 3))),
    "position 1-D": lambda f, p: _replace(f, "timeseries/position",
                                          f["timeseries/position"][()][:, 0].copy()),
    "position bytes": lambda f, p: _replace(f, "timeseries/position", np.array(
        [b"0.1"] * f["timeseries/position"].shape[0])),
    "phase 7": _code("phase", 7),
    "fault 65535": _code("fault", 65535),
    "state 200": _code("state", 200),
    "time NaN": lambda f, p: _replace(f, "timeseries/time", np.where(
        np.arange(f["timeseries/time"].shape[0]) == 5, np.nan, f["timeseries/time"][()])),
    "time backwards": lambda f, p: _replace(f, "timeseries/time",
                                            f["timeseries/time"][()][::-1].copy()),
    "external link": _external,
    "soft link": _soft,
    "hard alias": _hard_alias,
    "virtual dataset": _virtual,
    "events 10^8 rows": lambda f, p: f["events"].resize((10**8,)),
    "tick 10^8 rows": lambda f, p: f["timeseries/tick"].resize((10**8,)),
    "extra group": lambda f, p: f.create_group("extra").attrs.__setitem__("x", 1),
    "seal deleted": lambda f, p: f.attrs.__delitem__("seal"),
    "emg 5 columns for 3": _emg_columns,
    "emg time backwards": lambda f, p: _emg_time(f, lambda t: t.__setitem__(
        slice(10, 20), t[10:20][::-1].copy())),
    "emg time NaN": lambda f, p: _emg_time(f, lambda t: t.__setitem__(7, np.nan)),
    "mvc flags text": _mvc_flags_text,
    "emg notes cut": lambda f, p: f["emg"].attrs.__setitem__("notes",
                                                             '["the capture ended e'),
    "emg notes object": lambda f, p: f["emg"].attrs.__setitem__("notes",
                                                                '{"ended": "early"}'),
    "pose angle": lambda f, p: f["pose/angle"].__setitem__(
        (0, 0), f["pose/angle"][0, 0] + 0.1),
    "assistance level": lambda f, p: f["assistance"].attrs.__setitem__("level", 0.1),
}
RESEALED = ("parameters null", "position int32", "position (N,3)", "position 1-D",
            "position bytes", "phase 7", "fault 65535", "state 200", "time NaN",
            "time backwards", "external link", "soft link", "hard alias", "virtual dataset",
            "events 10^8 rows", "tick 10^8 rows", "emg 5 columns for 3", "emg time backwards",
            "emg time NaN", "mvc flags text", "emg notes cut", "emg notes object")
"""Edits a reader must refuse even when whoever made them sealed the file again: what no
trial the console records can hold."""


def trial_edits(corrupter: Corrupter, original: Path) -> list[Case]:
    from device.errors import RecordingError

    cases = []
    for edit in TRIAL_EDITS:
        for reseal in (False, True) if edit in RESEALED else (False,):
            target = corrupter._copy(original)
            try:
                _edit_trial(target, edit, reseal)
            except (KeyError, StopIteration, RecordingError):
                # the original has no such group, or the edit cannot even be sealed (a
                # link, a size beyond the file's: the reader's walk refuses it first)
                target.unlink()
                continue
            how = f"h5py edit: {edit}" + (" (sealed again)" if reseal else "")
            cases.append(Case("trial", how, str(target), str(original)))
    return cases


# -- edits of model files --------------------------------------------------------------------


def _rehashed(document: dict) -> dict:
    from app.learning.modelfile import content_hash
    from app.records import signing

    body = signing.unsigned(document)
    body["content_sha256"] = content_hash(body)
    if signing.SIGNATURE in document:
        body[signing.SIGNATURE] = document[signing.SIGNATURE]  # the signature stays
    return body


def model_edits(corrupter: Corrupter, kind: str, original: Path) -> list[Case]:
    """Edits of a model file: a value changed and the hash recomputed (the signature
    cannot be), the signature dropped, a weight of 1e308 signed (a file this installation
    signed that no trained model can be), NaN, a format_version in text, deep nesting."""
    from app.records import signing

    document = json.loads(original.read_text())
    edits: dict[str, str] = {}

    def edited(change) -> dict:
        copy = json.loads(json.dumps(document))
        change(copy)
        return copy

    if kind == "emg-model":
        def cone(d):
            for v in d["validations"]:
                v["force"]["tolerance_rad"] = v["force"]["tolerance_rad"] / 3
        edits["cone narrowed, rehashed"] = json.dumps(_rehashed(edited(cone)))
        first_weights = ("model",)
    else:
        def weight(d):
            name = sorted(d["weights"])[0]
            d["weights"][name]["values"][0] += 0.5
        edits["weight changed, rehashed"] = json.dumps(_rehashed(edited(weight)))
        huge = edited(lambda d: d["weights"][sorted(d["weights"])[0]]["values"].__setitem__(
            0, 1e308))
        edits["weight 1e308, signed"] = json.dumps(signing.sign(_rehashed(huge)))
        first_weights = ("weights",)
    edits["signature dropped, rehashed"] = json.dumps(signing.unsigned(
        _rehashed(edited(lambda d: None))))
    edits["name changed, rehashed"] = json.dumps(_rehashed(edited(
        lambda d: d.__setitem__("name", "renamed"))))
    edits["format_version text"] = json.dumps(edited(
        lambda d: d.__setitem__("format_version", "1")))
    edits["NaN"] = json.dumps(edited(lambda d: d.__setitem__("created_utc", float("nan"))))
    edits["nested 200k deep"] = "[" * 200_000 + "]" * 200_000
    del first_weights
    cases = []
    for how, text in edits.items():
        target = corrupter._copy(original)
        target.write_text(text)
        cases.append(Case(kind, f"edit: {how}", str(target), str(original)))
    return cases


# -- text files ------------------------------------------------------------------------------


def text_edits(corrupter: Corrupter, kind: str, original: Path) -> list[Case]:
    """Edits of a CSV a reader must refuse or read as written: a line over 131 KB, the
    header alone, NaN, time backwards, a letter in a number, a cell missing, binary."""
    lines = original.read_text(encoding="utf-8").splitlines()
    header_at = next(i for i, line in enumerate(lines)
                     if line and not line.startswith(("#", "Label:")) and line.strip())
    body = lines[header_at + 1:]
    k = len(body) // 2

    def with_body(new_body) -> str:
        return "\n".join(lines[:header_at + 1] + new_body) + "\n"

    def cell(row: str, value: str) -> str:
        cells = row.split(",")
        cells[1] = value
        return ",".join(cells)

    def time_back(row_a: str, row_b: str) -> list[str]:
        return [row_b, row_a]

    edits = {
        "a line of 200 KB": with_body([*body[:k], "1" * 200000, *body[k:]]),
        "header only": with_body([]),
        "NaN": with_body([*body[:k], cell(body[k], "nan"), *body[k + 1:]]),
        "time backwards": with_body(body[:k] + time_back(body[k], body[k + 1]) + body[k + 2:]),
        "letter in a number": with_body([*body[:k], cell(body[k], "1.2e-0x5"), *body[k + 1:]]),
        "a cell missing": with_body([*body[:k], body[k].rsplit(",", 1)[0], *body[k + 1:]]),
        "binary": "\x00\x01\x02" * 1000,
        "not UTF-8": None,
    }
    cases = []
    for how, text in edits.items():
        target = corrupter._copy(original)
        if text is None:
            target.write_bytes(b"time,a\n\xff\xfe0.0,1\n")
        else:
            target.write_text(text, encoding="utf-8")
        cases.append(Case(kind, f"edit: {how}", str(target), str(original)))
    return cases


def settings_edits(corrupter: Corrupter, original: Path) -> list[Case]:
    values = json.loads(original.read_text())
    edits = {
        "data_dir 123": {**values, "data_dir": 123},
        "data_dir empty": {**values, "data_dir": ""},
        "robot other": {**values, "robot": "rocket"},
        "flip_x text": {**values, "flip_x": "yes"},
    }
    texts = {how: json.dumps(v) for how, v in edits.items()}
    texts["NaN"] = original.read_text().replace("false", "NaN", 1)
    texts["nested 200k deep"] = '{"a":' * 200_000 + "1" + "}" * 200_000
    texts["format version text"] = json.dumps({**values, "settings_version": "1"})
    cases = []
    for how, text in texts.items():
        target = corrupter._copy(original)
        target.write_text(text)
        cases.append(Case("settings", f"edit: {how}", str(target), str(original)))
    return cases


def timestamps_edits(corrupter: Corrupter, original: Path) -> list[Case]:
    from device.camera.capture import timestamps_path

    lines = timestamps_path(original).read_text().splitlines()
    k = len(lines) // 2
    edits = {
        "NaN": [*lines[:k], f"{k - 1},nan", *lines[k + 1:]],
        "backwards": [*lines[:k], lines[k + 1], lines[k], *lines[k + 2:]],
        "a line of 200 KB": [*lines[:k], "7" * 200000, *lines[k:]],
        "header only": lines[:1],
        "missing half": lines[:k],
    }
    cases = []
    for how, new_lines in edits.items():
        def change(data: bytearray, new_lines=new_lines):
            data[:] = ("\n".join(new_lines) + "\n").encode()
            return ""
        case = corrupter.video_case("timestamps", original, f"edit: {how}", change)
        if case is not None:
            cases.append(case)
    return cases


# -- the originals ---------------------------------------------------------------------------


def make_originals(folder: Path, *, session=None, checked=None) -> dict[str, list[Path]]:
    """One file of each type as the console writes or reads it: a trial with EMG, its MVCs
    and a pose from its video (and the video with its timestamps), a headless as-needed
    trial, a learned model and an approved EMG model (signed here), a Trigno export and a
    plain EMG CSV, an MVC contraction, the settings, a registry with a patient and a trial.

    `session`: synthetic subject 1's recorded session (tests.emg_subjects.record_session),
    whose folder is copied here (its first trial is then given a pose: the copy, never the
    session given); recorded here without it. `checked`: an EMG model checked on that
    session (app.emg.validation.check_model), checked here without it. The suite passes
    the run's (tests/conftest.py emg_subject_1, emg_model_1)."""
    from app.emg.modelfile import save_approved
    from app.emg.subjects import Subject
    from app.emg.validation import check_model
    from app.learning.modelfile import write_model
    from app.pose.offline import estimate_pose
    from app.pose.synthetic import film
    from app.records.settings import Settings, save_settings
    from app.trials.headless import save, simulate
    from app.trials.reader import read_trial
    from core.learning import networks as nw
    from core.trial import THESIS_SUBJECT
    from device.emg.files import write_trigno_csv
    from tests.emg_subjects import record_session
    from tests.pose_film import ReplayDetector, write_video

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    out: dict[str, list[Path]] = {}

    if session is None:
        (folder / "session").mkdir()
        session = record_session(folder / "session")
    else:
        shutil.copytree(Path(session[0]).parent, folder / "session")
        session = [folder / "session" / Path(path).name for path in session]
    trial = session[0]
    filmed = film(read_trial(trial), seed=1, origin_s=100.0)
    video = write_video(trial.with_suffix(".avi"), filmed.stamps_s)
    estimate_pose(trial, ReplayDetector(filmed), video_start_s=float(filmed.true_frame_t_s[0]))
    plain = folder / "asneeded.h5"
    save(simulate(THESIS_SUBJECT.replace(repetitions=1, assist="as-needed"), patient="weak",
                  seed=3), plain)
    out["trial"] = [trial, plain]
    out["video"] = [video]
    out["timestamps"] = [video]

    spec = {"kind": "fnn", "dof": 2, "hidden": [4], "position_inputs": [0, 1],
            "input_mean": [0.0] * 6, "input_std": [1.0] * 6, "output_mean": [0.0] * 2,
            "output_std": [1.0] * 2}
    rng = np.random.default_rng(0)
    params = {k: rng.normal(size=s) for k, s in nw.param_shapes(spec).items()}
    models = folder / "models"
    models.mkdir()
    out["model"] = [write_model(models / "fnn.json", "fnn", spec, params,
                                {"system": "rehab-robot-simulator", "dof": 2}, {}, {})]
    from tests.emg_subjects import WIDE_CONE_RAD  # noqa: F401 - the session's cone
    if checked is None:
        checked = check_model(session, "network", test=[session[-1]], as_live=True,
                              latency_s=0.0)
    out["emg-model"] = [save_approved(models, "s1", checked)]

    subject = Subject.drawn(1)
    rate = subject.electrodes.rate_hz
    t = np.arange(400) / rate
    emg = np.random.default_rng(1).normal(0.0, 1e-4, (t.size, 3))
    out["emg-csv"] = [write_trigno_csv(folder / "trigno.csv", ["EMG1", "EMG2", "EMG3"], rate,
                                       emg, extra=(("ACC1.X", rate / 13, "g",
                                                    np.zeros(t.size // 13)),))]
    out["mvc-csv"] = sorted((folder / "session").glob("*mvc_biceps*.csv"))[:1]

    settings = folder / "settings.json"
    save_settings(Settings(data_dir=str(folder / "data"), flip_x=True, robot="simulator",
                           virtual_patient="weak"), settings)
    out["settings"] = [settings]
    out["registry"] = [_registry(folder / "registry")]
    return out


def registry_edits(corrupter: Corrupter, original: Path) -> list[Case]:
    """Edits of the registry made without the console (the sqlite3 shell, a database
    browser): a row's value changed with the seal triggers dropped (with them in place the
    edit fails: no such function registry_seal), a row's seal set to another's."""
    import sqlite3

    edits = {
        "patient's name (triggers dropped)": [
            "DROP TRIGGER patients_sealed_on_update",
            "UPDATE patients SET first_name = 'Eve' WHERE code = (SELECT MIN(code) FROM "
            "patients)"],
        "patient's side (triggers dropped)": [
            "DROP TRIGGER patients_sealed_on_update",
            "UPDATE patients SET side = CASE side WHEN 'left' THEN 'right' ELSE 'left' END"],
        "patient's mass as text (triggers dropped)": [
            "DROP TRIGGER patients_sealed_on_update",
            "UPDATE patients SET body_mass_kg = '70'"],
        "seal swapped": [
            "UPDATE patients SET seal = (SELECT seal FROM patients ORDER BY id DESC LIMIT 1) "
            "WHERE id = (SELECT MIN(id) FROM patients)"],
        "seal removed": ["UPDATE patients SET seal = NULL"],
        "trial's status (triggers dropped)": [
            "DROP TRIGGER trials_sealed_on_update",
            "UPDATE trials SET status = 'stopped_early'"],
        "trial's metric (triggers dropped)": [
            "DROP TRIGGER trials_sealed_on_update",
            "UPDATE trials SET metrics = replace(metrics, '0.0123', '0.0023')"],
    }
    cases = []
    for how, statements in edits.items():
        target = corrupter._copy(original)
        conn = sqlite3.connect(_file_of(target), isolation_level=None)
        try:
            for statement in statements:
                conn.execute(statement)
        finally:
            conn.close()
        cases.append(Case("registry", f"sqlite3 edit: {how}", str(target), str(original)))
    return cases


def _registry(folder: Path) -> Path:
    """A data folder whose registry holds two patients, the first with a finished trial
    (its session, parameters, status and metrics)."""
    from app.records.registry import Registry
    from core.trial import TrialParameters

    registry = Registry(folder, create=True)
    ada = registry.create_patient("Ada", "Example", body_mass_kg=70.0, upper_arm_m=0.3,
                                  forearm_m=0.28, side="right")
    registry.create_patient("Bo", "Sample", body_mass_kg=80.0, upper_arm_m=0.32,
                            forearm_m=0.3, side="left")
    begun = registry.begin_trial(ada.code, TrialParameters(), backend="simulator")
    registry.finish_trial(begun.trial_id, "complete", {"rmse_m": 0.0123, "peak_force_n": 7.5})
    return folder


def make_cases(originals: dict[str, list[Path]], folder: Path, *, per_file: int, seed: int,
               edits: bool = True) -> list[Case]:
    """Byte-level damage (`per_file` cases each original, a quarter of the flips in the
    first 4 KB) and, with `edits`, every named edit of each type."""
    corrupter = Corrupter(folder, seed)
    cases: list[Case] = []
    for kind, paths in originals.items():
        for original in paths:
            n = per_file * (3 if kind == "trial" else 1)
            cases += corrupter.damage(kind, original, n, head=4096,
                                      video=kind in ("video", "timestamps"))
            if not edits:
                continue
            if kind == "trial" and original == paths[0]:  # the one with every group
                cases += trial_edits(corrupter, original)
            elif kind in ("model", "emg-model"):
                cases += model_edits(corrupter, kind, original)
            elif kind in ("emg-csv", "mvc-csv"):
                cases += text_edits(corrupter, kind, original)
            elif kind == "settings":
                cases += settings_edits(corrupter, original)
            elif kind == "registry":
                cases += registry_edits(corrupter, original)
            elif kind == "timestamps":
                cases += timestamps_edits(corrupter, original)
    return cases


def environment(config: Path) -> dict:
    """The worker's environment: the config folder whose key signed the models."""
    return {**os.environ, "REHAB_CONFIG_DIR": str(config), "PYTHONPATH": str(ROOT)}


def elapsed(start: float) -> str:
    return f"{time.perf_counter() - start:.0f} s"
