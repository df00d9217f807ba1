"""Where this station finds a registered trial's file: its data folder, else the copy in the
department's shared trial store (issue 32; app.records.trialstore), else — a trial another
station recorded on a shared registry and has not copied yet — at that station.

On a server's registry each station writes its trial files into its own data folder, so a
patient seen at robot-1 and robot-2 has files in two folders; each station copies its own
into the store after each trial (`trials.stored_in`, schema v11). A file that is in none
of the places this station can read is then one of two things, which a therapist must not
confuse: a trial of another station not yet copied (it is there, on that station) and a
file lost (missing here, or from the store that recorded holding it). On the data folder's
own SQLite registry every console writing to it shares that folder: a file not there is
missing, whichever station recorded it.

Two ways of asking, for two costs:

* `TrialPlaces.state`: what the Progress tab and `rehab progress` show for each of a
  patient's trials (app.reports.progress): each file opened and its 8-byte HDF5 signature
  read (about 4 µs a file on a local disk), the store only for a file not whole here;
* `file_to_read`: the file Replay opens; the store's copy only when its SHA-256 is the
  checksum kept at the trial's end (Registry.verify_trial_file's rule): it comes over the
  network from another station's copy.
"""

from __future__ import annotations

import os
from pathlib import Path

from app.errors import AppError
from app.records.registry import Trial, TrialSummary
from app.records.registry.provenance import file_checksum
from app.records.store import RecordStore

FILE_OK = "ok"
"""Whole in this station's data folder."""
FILE_IN_STORE = "in_store"
"""Not whole here; the shared trial store's copy is (read from there)."""
FILE_AT_STATION = "at_station"
"""Not here, and the station that recorded it (another, on a shared registry) has not
copied it into the trial store yet: it is on that station."""
FILE_STORE_UNREACHABLE = "store_unreachable"
"""Not whole here; the trial store recorded as holding it is not reachable from here (its
folder is not there: the network folder not mounted)."""
FILE_OF_ANOTHER = "of_another"
"""A row finished as recording lost, with no file of its own: the file of its name is
another trial's recording, which the sync registered under a second name
(app.records.station.secondname). Never opened for it."""
FILE_MISSING = "missing"
FILE_UNREADABLE = "unreadable"
FILE_UNCHECKED = "unchecked"

FILE_USABLE = frozenset((FILE_OK, FILE_IN_STORE, FILE_UNCHECKED))
"""The states whose trial can be opened here (Replay, a report)."""

HDF5_SIGNATURE = b"\x89HDF\r\n\x1a\n"
STATUS_LOST = "recording_lost"


class TrialPlaces:
    """Where this station finds the files of many trials: made once for a patient's
    progress (its data folder's root, this station, whether the registry is shared, and
    each trial store's folder checked once)."""

    def __init__(self, registry: RecordStore) -> None:
        self.registry = registry
        self.root = str(registry.data_dir.root).rstrip("/\\") + os.sep
        self.station = registry.station
        # location() is '' for the data folder's own registry, where every station's files
        # are in that one folder
        self.shared = bool(registry.location())
        self._reachable: dict[str, bool] = {}
        self._second_names: dict[str, dict[str, int]] = {}  # per patient, read once

    def trial_state(self, trial: Trial | TrialSummary, code: str) -> str:
        """The state of patient `code`'s trial's file (FILE_*): `state`, or FILE_OF_ANOTHER
        for a row finished as recording lost under the name of another trial's file."""
        if self.recording_of_name(trial, code) is not None:
            return FILE_OF_ANOTHER
        return self.state(trial.file, trial.stored_in, trial.station, trial.checksum)

    def recording_of_name(self, trial: Trial | TrialSummary, code: str) -> int | None:
        """For a row of patient `code` finished as recording lost: the id of the trial
        whose recording the file of its name is, when the sync registered that one under a
        second name (its `trial_file` correction, app.records.station.secondname); None
        when the file of its name is its own. The registered name, the first one, was the
        row's too: opened for it, that trial's recording was shown as the lost row's. Only
        lost rows ask the registry, once per patient."""
        if trial.status != STATUS_LOST:
            return None
        names = self._second_names.get(code)
        if names is None:
            names = self._second_names[code] = {
                c.old_value["file"]: c.old_value["trial_id"]
                for c in self.registry.corrections(code)
                if c.field == "trial_file" and isinstance(c.old_value, dict)}
        owner = names.get(trial.file)
        return owner if owner != trial.id else None

    def state(self, file: str, stored_in: str | None, station: str | None,
              checksum: str | None = None) -> str:
        """The state of a trial's file (FILE_*) from what the registry records of it: its
        relative path, the store holding its copy and the station that recorded it; with its
        `checksum`, a file of its name here that is not it is taken for none (below)."""
        here = _signature(self.root, file)
        if here == FILE_OK and checksum is not None and self.elsewhere(station) \
                and file_checksum(self.root + file) != checksum:
            # Another station's trial, and a file of its name here that is another: this
            # station's own recording, registered under a second name because that trial
            # has its name (app.records.station.secondname). Only such an oddity is hashed:
            # another station's files are not in this folder.
            here = FILE_MISSING
        if here == FILE_OK:
            return FILE_OK
        if stored_in is not None:
            if not self.store_reachable(stored_in):
                return FILE_STORE_UNREACHABLE
            stored = _signature(stored_in.rstrip("/") + "/", file)
            if stored == FILE_OK:
                return FILE_IN_STORE
            # a file damaged here says so; one missing here says what the store's is
            return here if here != FILE_MISSING else stored
        if here == FILE_MISSING and self.elsewhere(station):
            return FILE_AT_STATION
        return here

    def elsewhere(self, station: str | None) -> bool:
        """Whether a trial recorded by `station` keeps its file in another station's data
        folder (a shared registry's other station), not in this one's."""
        return self.shared and station is not None and station != self.station

    def store_reachable(self, stored_in: str) -> bool:
        reachable = self._reachable.get(stored_in)
        if reachable is None:
            reachable = self._reachable[stored_in] = os.path.isdir(stored_in)
        return reachable


def file_to_read(registry: RecordStore, trial: Trial, *, checked: bool = True
                 ) -> tuple[Path, str]:
    """The file to open for a registered trial on this station, and a note when it is the
    shared trial store's copy ('' otherwise). The data folder's file when it is whole
    (read as it always was); else the store's copy, only when its SHA-256 is the checksum
    kept at the trial's end (`checked` False: on its HDF5 signature, as the progress's
    file state takes it; for a count over many trials' files, the plans' dose). AppError
    (one line) when neither can be read here: a trial of another station not yet in the
    store says so and where it is; a file missing or damaged here and never copied is the
    reader's to name (the path returned)."""
    if lost := no_file_of_its_own(registry, trial):
        raise AppError(lost)
    places = TrialPlaces(registry)
    # named as the lists name it (Replay's, the Progress table's), with the id the
    # command line takes
    named = _named(trial)
    here = registry.trial_path(trial)
    state = places.state(trial.file, trial.stored_in, trial.station, trial.checksum)
    if state == FILE_OK or (state in (FILE_MISSING, FILE_UNREADABLE)
                            and trial.stored_in is None):
        return here, ""
    if state == FILE_AT_STATION:
        raise AppError(f"the file of {named} is on station {trial.station}, not yet in the "
                       f"trial store: open it at {trial.station}, or here once that station "
                       "has copied it (it does after each trial, when it reaches the store)")
    copy = Path(trial.stored_in, trial.file)
    note = f"read from the trial store's copy {copy}"
    if state == FILE_IN_STORE and not checked:
        return copy, note
    if state == FILE_STORE_UNREACHABLE:
        raise AppError(f"the file of {named} is not in this station's data folder and the "
                       f"trial store {trial.stored_in} holding its copy cannot be reached "
                       "from here (is the network folder mounted?)")
    try:
        found = file_checksum(copy)
    except OSError as exc:
        raise AppError(f"the file of {named} is not in this station's data folder and its "
                       f"copy in the trial store {copy} cannot be read "
                       f"({exc.strerror or exc}): restore it from a backup") from None
    if trial.checksum is not None and found != trial.checksum:
        raise AppError(f"the copy of {named} in the trial store {copy} is not the file "
                       f"recorded: its SHA-256 is {found[:12]}…, the registry's "
                       f"{trial.checksum[:12]}… (changed or replaced since the trial ended); "
                       "it is not opened: restore it from a backup")
    return copy, note


def no_file_of_its_own(registry: RecordStore, trial: Trial) -> str:
    """'' but for a row finished as recording lost under the name of another trial's file
    (TrialPlaces.recording_of_name): then why nothing is opened for it, in the words
    Replay, the report and the exports say. Asks the registry only for a lost row."""
    if trial.status != STATUS_LOST:
        return ""
    owner = TrialPlaces(registry).recording_of_name(trial, trial.patient_code)
    if owner is None:
        return ""
    return (f"{_named(trial)} was recorded as lost and has no file of its own: the file of "
            f"its name is the recording of {_named(registry.trial(owner))}, which the "
            "registry keeps under a second name")


def _named(trial: Trial) -> str:
    return f"session {trial.session_number}, trial {trial.number} (id {trial.id})"


def _signature(root: str, file: str) -> str:
    """root ends with a separator. Plain string work: pathlib and os.path.join
    cost more than the open itself, 1,000 times over."""
    if file.startswith("/") or ".." in file.split("/") or ":" in file or "\\" in file:
        return FILE_UNREADABLE  # not a path the registry writes
    try:
        fd = os.open(root + (file if os.sep == "/" else file.replace("/", os.sep)),
                     os.O_RDONLY)
    except FileNotFoundError:
        return FILE_MISSING
    except OSError:  # no permission, a folder
        return FILE_UNREADABLE
    try:
        head = os.read(fd, len(HDF5_SIGNATURE))
    except OSError:
        return FILE_UNREADABLE
    finally:
        os.close(fd)
    # HDF5 files written by h5py without a user block carry the signature at 0.
    return FILE_OK if head == HDF5_SIGNATURE else FILE_UNREADABLE
