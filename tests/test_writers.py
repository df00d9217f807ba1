"""Every place the console writes, replaces, removes or changes the mode of a file is known
(issue 28 #1: `rehab learn … --output` replaced the registry, a trial file, a model, through
writers of their own that did not go through the one guarded write).

The console's code (app, core, device, ui) is read as Python and every call that writes to
the file system is listed: open() for writing, h5py's writing modes, write_text and
write_bytes, savemat/np.save/tofile, json and pickle dumps, copies, renames, links, removals,
SQLite connections and backups, OpenCV's video writer, figures saved by name, folders made,
modes changed. A call of the guarded write itself (device.safewrite, app.records.safewrite,
app.exports.files' output) is not listed: those check the name, never write over a file
unless asked nor over what a data folder keeps, write whole and 0600.

`KNOWN` is what remains, each with why it is not, or need not be, the guarded write. A new
writer fails this test until it goes through device.safewrite / app.records.safewrite, or
is added here with its reason (for a reviewer to judge).
"""

from __future__ import annotations

import ast
import collections
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGES = ("app", "core", "device", "ui")
GUARDED = ("device.safewrite", "app.records.safewrite", "app.exports.files")
"""Modules whose writing functions are the guarded write (a call of a name imported from
one of them is not listed)."""
THE_GUARDED_WRITE = ("device/safewrite.py",)
"""The guarded write's own system calls."""

KNOWN: dict[tuple[str, str], tuple[int, str]] = {
    # (file, call): (how many, why)
    ("app/cli/main.py", "os.open for writing"): (
        1, "/dev/null, to silence stdout once its reader has gone (no file is written)"),
    ("app/exports/files.py", "tempfile.mkstemp"): (
        1, "a write probe in an export folder already checked: an empty 0600 file, removed"),
    ("app/exports/files.py", "os.unlink"): (1, "the write probe's removal"),
    ("app/exports/mat.py", "io.savemat"): (
        1, "into the stream of app.exports.files.output (the guarded write)"),
    ("app/exports/plan.py", "os.unlink"): (
        1, "a batch's outputs of a trial that failed half-way, those that did not exist before"),
    ("app/learning/components.py", "fig.savefig"): (
        1, "into the stream of app.records.safewrite.atomic_output"),
    ("app/learning/dataset.py", "h5py.File('w')"): (
        1, "on the temporary of app.records.safewrite.atomic_path"),
    ("app/records/datadir.py", "os.mkdir"): (
        1, "the data folder's own folders, 0700, never the root (device.safewrite makes it)"),
    ("app/records/datadir.py", "os.chmod"): (
        3, "the data folder's own folders and SQLite files, closed to their user again; "
           "never a folder the console did not make"),
    ("app/records/datadir.py", "tempfile.mkstemp"): (
        1, "a write probe in the data folder: an empty 0600 file, removed at once"),
    ("app/records/datadir.py", "os.unlink"): (1, "the write probe's removal"),
    ("app/records/logs.py", "os.open for writing"): (
        1, "the day's log, appended to by every process all day: created 0600, not whole"),
    ("app/records/logs.py", "os.fchmod"): (1, "the day's log closed to its user again"),
    ("app/records/logs.py", "os.fdopen('a')"): (1, "the day's log, on the descriptor above"),
    ("app/records/logs.py", "path.unlink"): (1, "day logs older than the days kept"),
    ("app/records/registry/database.py", "sqlite3.connect"): (
        3, "the registry's own connections (SQLite's journal makes each write whole) and "
           "Registry.backup's copy, into atomic_path's temporary"),
    ("app/records/registry/database.py", "conn.backup"): (
        1, "Registry.backup: into the temporary of app.records.safewrite.atomic_path"),
    ("app/records/registry/schema.py", "sqlite3.connect"): (
        2, "a new registry and the copy before a migration, built in atomic_path's temporary"),
    ("app/records/registry/schema.py", "conn.backup"): (
        1, "the copy before a migration, into atomic_path's temporary"),
    ("app/records/registry/schema.py", "os.unlink"): (
        1, "the new registry's temporary -wal and -shm, once its only connection closed"),
    ("app/records/registry/snapshot.py", "sqlite3.connect"): (1, "':memory:', no file"),
    ("app/records/station/standby.py", "open('a')"): (
        1, "the standby's lock file, opened to hold an advisory lock for the console's life; "
           "nothing is written to it"),
    ("app/records/station/standby.py", "os.rename"): (
        1, "a damaged standby moved aside as damaged-<UTC>.sqlite3, kept whole, never read"),
    ("app/records/station/secondname.py", "os.link"): (
        1, "a trial file's second name (its number on the server) as a hard link to the file "
           "recorded: a link fails when the name is taken, so it is never over a file, and "
           "the file recorded is left as it is"),
    ("app/records/station/secondname.py", "path.unlink"): (
        1, "the second names this sync attempt made, taken away when the server's "
           "transaction does not commit (links to files that stay under their first names)"),
    ("app/records/station/waiting.py", "sqlite3.connect"): (
        1, "the standby read only (mode=ro), for `rehab db status` to say what waits in it"),
    ("app/records/station/waiting.py", "unlink"): (
        1, "the kept refusal of a sync (offline/sync-refused.txt, written by the guarded "
           "write), removed once a sync went through: it would say a refusal that no longer "
           "holds"),
    ("app/records/station/refresh.py", "sqlite3.connect"): (
        2, "the standby brought to the server's rows in place, in one transaction, only while "
           "it holds nothing unsent (as the station last left it); and its manifest read "
           "read-only (mode=ro) before the server is asked"),
    ("app/records/station/mirror.py", "tempfile.mkstemp"): (
        1, "the standby built aside in the station's offline/ folder (0600)"),
    ("app/records/station/mirror.py", "sqlite3.connect"): (
        3, "on that temporary; and the standby as it was sent (keep_sent), copied by "
           "SQLite's backup into the temporary of app.records.safewrite.atomic_path (a new "
           "file, never over one)"),
    ("app/records/station/mirror.py", "source.backup"): (1, "that copy"),
    ("app/records/station/mirror.py", "os.replace"): (
        1, "the standby replaced by its new build, only when it holds nothing unsent (its "
           "rows checked against its manifest first): a mirror of the server's rows, which "
           "the server keeps"),
    ("app/records/station/mirror.py", "os.unlink"): (
        3, "the last build's -wal and -shm before the replace; the temporary when the build "
           "fails; the standby once sent and kept as synced-<UTC>.sqlite3 (its -wal and -shm "
           "too)"),
    ("app/records/trialstore.py", "os.open for writing"): (
        1, "a trial's copy in the shared trial store, written aside under a new name "
           "(O_EXCL, 0600), fsynced and hashed before it is put in place"),
    ("app/records/trialstore.py", "os.fdopen('wb')"): (1, "on that descriptor"),
    ("app/records/trialstore.py", "os.link"): (
        1, "the copy put in place: a link fails when the name is taken, so never over a file"),
    ("app/records/trialstore.py", "os.rename"): (
        1, "the same where the share cannot link, after checking the name is free"),
    ("app/records/trialstore.py", "partial.unlink"): (1, "the copy's temporary name"),
    ("app/records/trialstore.py", "target.unlink"): (
        1, "a copy this call made that read back differently from the store"),
    ("app/records/registry/admin.py", "sqlite3.connect"): (
        1, "rehab db status opens the registry read-only (mode=ro): it writes nothing"),
    ("app/study/outputs.py", "os.mkdir"): (
        1, "the study's Parquet dataset is written into a fresh private folder of its own "
           "(0700, beside the output), never into one that exists"),
    ("app/study/outputs.py", "os.chmod"): (
        3, "the fresh dataset folder's files and folders made the user's only before it is "
           "renamed into place"),
    ("app/study/outputs.py", "os.rename"): (
        3, "the dataset renamed into place whole (a rename fails over a folder with files: "
           "nothing of another's is replaced); with --overwrite the old one moved aside "
           "first and back when the rename fails"),
    ("app/study/outputs.py", "shutil.rmtree"): (
        2, "the study's own temporary folder, and with --overwrite its own previous "
           "results once the new ones are in place"),
    ("app/study/run.py", "failures.rename"): (
        1, "a pandas DataFrame's columns renamed, no file"),
    ("app/records/settings.py", "os.replace"): (
        1, "a damaged settings file set aside, in the console's own config folder, to a name "
           "found free"),
    ("app/reports/pdf_file.py", "PdfPages"): (
        1, "into the stream of app.records.safewrite.atomic_output"),
    ("app/reports/pdf_file.py", "pdf.savefig"): (1, "pages into that PdfPages"),
    ("app/trials/registered.py", "os.unlink"): (
        1, "a refused trial's file that holds no sample, withdrawn with its registry row"),
    ("app/trials/rewrite.py", "os.open for writing"): (
        2, "the mark of a write into a finished trial's file (O_EXCL, O_NOFOLLOW, 0600: its "
           "lock and a line of JSON, made before the write), and reopening it to settle"),
    ("app/trials/rewrite.py", "where.unlink"): (
        3, "the mark removed once the registry holds the file's new checksum"),
    ("core/blockwise.py", "speed.tofile"): (1, "an anonymous temporary file (no name)"),
    ("device/camera/capture.py", "cv2.VideoWriter"): (
        1, "a video grows as it is filmed: on a file claimed exclusively and 0600 first "
           "(device.safewrite.claim_private_file), never over one"),
    ("device/camera/capture.py", "path.unlink"): (
        1, "the files made for a video that could not start"),
    ("device/camera/detector.py", "open('wb')"): (1, "/dev/null"),
    ("device/compiled/cachedir.py", "probe.write_bytes"): (
        1, "a write probe in the kernels' cache, a folder checked to be the user's alone"),
    ("device/compiled/cachedir.py", "probe.unlink"): (1, "the probe's removal"),
    ("device/compiled/warmup.py", "shutil.rmtree"): (
        1, "earlier sources' caches beside this one, in that private cache folder"),
    ("device/loop/client.py", "ring.unlink"): (1, "shared memory, not a file"),
    ("device/recording/ring.py", "self.unlink"): (1, "shared memory, not a file"),
    ("device/recording/trialfile/making.py", "h5py.File('w')"): (
        1, "a trial file grows as it is recorded: on a hidden name claimed exclusively and "
           "0600 first (device.safewrite.claim_private_file)"),
    ("device/recording/trialfile/making.py", "os.link"): (
        1, "the made trial file takes its name, never over a file"),
    ("device/recording/trialfile/making.py", "os.rename"): (
        1, "the same where a file system has no hard links, the name checked free"),
    ("device/recording/trialfile/making.py", "os.unlink"): (
        2, "the hidden name, once linked; a file HDF5 could not make"),
    ("device/recording/trialfile/writer.py", "h5py.File('r+')"): (
        1, "the writer's own file reopened at its close for the status and summary, in space "
           "held for it"),
    ("device/recording/trialfile/writer.py", "os.unlink"): (
        1, "the hidden file of a trial that could not start"),
    ("device/recording/trialfile/update.py", "h5py.File('r+')"): (
        1, "open_for_update: a group added to a closed trial file (metrics, EMG, pose) in "
           "space held for it"),
    ("device/recording/trialfile/resume.py", "h5py.File('r+')"): (
        1, "a dead recorder's own trial file taken over to finish it from the ring (salvage)"),
    ("device/lsl/library.py", "os.open for writing"): (
        1, "os.devnull, where liblsl's one line about its log file goes while it reads its "
           "configuration (stderr restored after)"),
    ("device/recording/trialfile/recover.py", "os.open for writing"): (
        1, "clearing a dead writer's open-for-write flags in a trial file (h5clear -s)"),
    ("device/recording/trialfile/reserve.py", "os.open for writing"): (
        1, "disk space held beyond the end of a trial file being written (fallocate)"),
    ("ui/window/station.py", "old.unlink"): (
        1, "a report PDF in reports/ named and headed with the number a station's sync "
           "changed, removed once written anew under the registry's"),
    ("ui/window/trial.py", "path.unlink"): (
        1, "the video and its timestamps begun for a trial the loop refused, withdrawn"),
}

_TABLE = {"write_text", "write_bytes", "savemat", "save", "savez", "savez_compressed",
          "savetxt", "tofile", "dump", "copy", "copy2", "copyfile", "copytree", "move",
          "replace", "rename", "link", "symlink", "touch", "symlink_to", "hardlink_to",
          "VideoWriter", "connect", "mkstemp", "NamedTemporaryFile", "savefig", "mkdir",
          "makedirs", "chmod", "fchmod", "lchmod", "chown", "unlink", "remove", "rmtree",
          "backup", "imwrite", "PdfPages", "truncate"}
_OWNED_BY = {"replace": ("os",), "connect": ("sqlite3",), "save": ("np", "numpy"),
             "dump": ("json", "pickle"), "copy": ("shutil",), "move": ("shutil",),
             "remove": ("os",), "truncate": ("os",)}
"""Names that are writers only on these modules (str.replace, dataclasses' replace …)."""
_WRITE_FLAGS = {"O_WRONLY", "O_RDWR", "O_CREAT", "O_APPEND", "O_TRUNC"}
GUARDED_OWNERS = ("safewrite",)
"""`safewrite.write_text(...)` and the like, by the module's name."""


def _text(node) -> str | None:
    return node.value if isinstance(node, ast.Constant) and isinstance(node.value, str) else None


def _mode(call: ast.Call, position: int) -> str | None:
    for keyword in call.keywords:
        if keyword.arg == "mode":
            return _text(keyword.value)
    return _text(call.args[position]) if len(call.args) > position else None


def _writer(call: ast.Call, guarded: set[str]) -> str | None:
    """What kind of writer `call` is, or None (a read, or not the file system's)."""
    f = call.func
    if isinstance(f, ast.Name):
        name, owner = f.id, None
        if name in guarded:
            return None
    elif isinstance(f, ast.Attribute):
        name = f.attr
        owner = (f.value.id if isinstance(f.value, ast.Name)
                 else f.value.attr if isinstance(f.value, ast.Attribute) else "")
    else:
        return None
    if name == "open" and owner == "os":
        flags = {n.attr for n in ast.walk(call.args[1]) if isinstance(n, ast.Attribute)} \
            if len(call.args) > 1 else set()
        return "os.open for writing" if flags & _WRITE_FLAGS else None
    if name in ("open", "fdopen"):
        # open(path, mode) and os.fdopen(fd, mode); path.open(mode)
        mode = _mode(call, 1 if owner in (None, "os", "io", "builtins") else 0)
        if mode and set(mode) & set("wax+"):
            return f"{'os.' if owner == 'os' else ''}{name}({mode!r})"
        return None
    if name == "File" and owner == "h5py":
        mode = _mode(call, 1)
        return None if mode == "r" else f"h5py.File({mode!r})"
    if name not in _TABLE or owner in GUARDED_OWNERS:
        return None
    if name in _OWNED_BY and owner not in _OWNED_BY[name]:
        return None
    return f"{owner}.{name}" if owner else name


def writers() -> collections.Counter:
    found = collections.Counter()
    for package in PACKAGES:
        for path in sorted((ROOT / package).rglob("*.py")):
            relative = path.relative_to(ROOT).as_posix()
            if relative in THE_GUARDED_WRITE:
                continue
            tree = ast.parse(path.read_text(encoding="utf-8"), filename=relative)
            guarded = {alias.asname or alias.name for node in ast.walk(tree)
                       if isinstance(node, ast.ImportFrom) and node.module in GUARDED
                       for alias in node.names}
            for node in ast.walk(tree):
                if isinstance(node, ast.Call):
                    kind = _writer(node, guarded)
                    if kind:
                        found[(relative, kind)] += 1
    return found


def test_every_writer_is_the_guarded_write_or_known_with_its_reason():
    found = writers()
    known = {place: count for place, (count, _) in KNOWN.items()}
    new = {place: n for place, n in found.items() if known.get(place, 0) < n}
    gone = {place: n for place, n in known.items() if found.get(place, 0) < n}
    assert not new, ("writers that do not go through device.safewrite or app.records."
                     f"safewrite: {new}; write through them, or add each to KNOWN with why")
    assert not gone, f"KNOWN lists writers that are no longer there: {gone}; take them out"


def test_the_list_of_writers_finds_the_writers_it_must():
    """The reader of the code sees a writer in each of the forms the console has used."""
    source = """
import h5py, os, shutil, sqlite3, json
from pathlib import Path
from device.safewrite import write_text
def f(p, q, fd):
    open(p, "w"); Path(p).open("ab"); h5py.File(p, "w-"); h5py.File(p, mode="a")
    Path(p).write_text("x"); shutil.copy2(p, q); os.replace(p, q); sqlite3.connect(p)
    os.open(p, os.O_WRONLY | os.O_CREAT); json.dump({}, fd); os.fdopen(fd, "w")
    open(p); h5py.File(p, "r"); os.open(p, os.O_RDONLY); "a".replace("a", "b")
    write_text(p, "guarded")
"""
    tree = ast.parse(source)
    guarded = {"write_text"}
    kinds = [k for node in ast.walk(tree) if isinstance(node, ast.Call)
             for k in [_writer(node, guarded)] if k]
    assert sorted(kinds) == sorted([
        "open('w')", "open('ab')", "h5py.File('w-')", "h5py.File('a')", "write_text",
        "shutil.copy2", "os.replace", "sqlite3.connect", "os.open for writing", "json.dump",
        "os.fdopen('w')"])
