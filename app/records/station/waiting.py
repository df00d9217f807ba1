"""What this station recorded while the shared registry was unreachable and has not sent
yet, as `rehab db status` says it (issue 32: "does `rehab db status` say what is true?").

The server's counts alone said a station's day was all there ("trials 7 … every row
matches its seal") while two of its trials were still only in its standby,
`offline/registry.sqlite3`, until the window sends them. Only the window sends them
(app.records.station.StationRegistry.try_sync); the command line uses the server only, so
the line says so. The standby is read, never written: opened read-only, no lock taken
(a window holding it meanwhile is undisturbed).

When the window's last attempt to send them was refused (a row another station changed
meanwhile: app.records.station.sync; a number another station gave is no refusal, the sync
renumbers), the line says that refusal instead of
"the window sends them": the station keeps it beside the standby (`sync-refused.txt`, one
line, removed by the next sync that goes through). The line said the window would send them
while every attempt was refused, and the admin waited for a sync that could not come.
"""

from __future__ import annotations

import contextlib
import datetime
import sqlite3
from pathlib import Path

from app.records.datadir import DataDir
from app.records.safewrite import write_text
from app.records.station.mirror import changes, manifest, standby_path, standby_rows


def waiting_line(data_dir: DataDir) -> str | None:
    """One line naming what this station's standby holds that the server did not have
    when it was mirrored (trials, and every record in all), or why it cannot be read; None
    when there is no standby or nothing waits in it."""
    path = standby_path(data_dir)
    if not path.exists():
        return None
    try:
        with contextlib.closing(sqlite3.connect(f"{path.as_uri()}?mode=ro", uri=True)) as conn:
            work = changes(standby_rows(conn), manifest(conn))
    except sqlite3.Error as exc:
        return (f"this station: its standby registry {path} cannot be read ({exc}); records "
                "made while the shared registry was unreachable may wait in it")
    if not work:
        return None
    trials = sum(change.table == "trials" and change.mirrored is None for change in work)
    refused = last_refusal(data_dir)
    then = (f"the window's last attempt to send them ({refused}" if refused else
            "the console's window sends them once it runs and the server answers (the "
            "command line does not)")
    return (f"this station: {trials} trial(s) ({len(work)} record(s) in all) recorded or "
            f"changed while the shared registry was unreachable wait in {path}, not on the "
            f"server yet: {then}")


def refusal_path(data_dir: DataDir) -> Path:
    return standby_path(data_dir).with_name("sync-refused.txt")


def keep_refusal(data_dir: DataDir, problem: str) -> None:
    """Keep the sync's refusal (`problem`, one line) beside the standby, with its time."""
    when = datetime.datetime.now(datetime.UTC).strftime("%Y-%m-%d %H:%M UTC")
    write_text(refusal_path(data_dir), f"{when}) was refused: {problem}\n", overwrite=True,
               owned=True)


def clear_refusal(data_dir: DataDir) -> None:
    with contextlib.suppress(FileNotFoundError):
        refusal_path(data_dir).unlink()


def last_refusal(data_dir: DataDir) -> str | None:
    """The kept refusal's line, or None (none kept, or not readable as one line)."""
    try:
        text = refusal_path(data_dir).read_text(encoding="utf-8")
    except (OSError, UnicodeError):
        return None
    line = text.strip()
    return line if line and "\n" not in line else None
