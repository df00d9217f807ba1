"""A guard over the whole suite: every trial file a test leaves in its data folder is the
file its registry recorded.

The registry keeps the SHA-256 of each trial's file as finished (and again after each of the
console's own writes into it, app.trials.rewrite); exports, studies and the trial store read
a registered trial only when its file still has that checksum. A console path that writes
into a finished trial's file without recording its new checksum therefore drops the trial
from every export silently: seven such paths were found one by one (the circle task, EMG
import and MVC, pose, the window's live EMG, its MVC re-recorded, the Replay tab's pose).
Rather than a test per path, every test that used `tmp_path` is checked after it ends, so a
new path that forgets the bracket fails the first test that runs it.

A test that changes a trial file behind the registry's back on purpose (a corruption or
tamper test) says so with `@pytest.mark.changes_recorded_files`.
"""

from __future__ import annotations

import contextlib
import sqlite3
from pathlib import Path

from app.records.datadir import REGISTRY_NAME
from app.records.registry.provenance import file_checksum

MARK = "changes_recorded_files"


def changed_trial_files(root: Path) -> list[str]:
    """One line per registered trial under `root` whose file exists and is not the one its
    registry recorded. A registry that cannot be read (a corruption test's, or one from
    before checksums were kept) is left to the test that made it."""
    found = []
    for registry in sorted(root.rglob(REGISTRY_NAME)):
        try:
            with contextlib.closing(sqlite3.connect(f"file:{registry}?mode=ro",
                                                    uri=True)) as db:
                rows = db.execute("SELECT id, file, checksum FROM trials "
                                  "WHERE checksum IS NOT NULL").fetchall()
        except sqlite3.Error:
            continue
        for trial_id, file, checksum in rows:
            path = registry.parent / file
            try:
                if file_checksum(path) != checksum:
                    found.append(f"trial {trial_id}'s file {path} is not the file its "
                                 f"registry recorded (changed after it was finished)")
            except OSError:  # moved, deleted or unreadable: the test's own business
                continue
    return found
