"""Writing a PDF of matplotlib pages as every file the console writes by a name is written
(device.safewrite): into a 0600 temporary beside its name, fsynced, then moved into place,
never over a file unless asked and never half-written; and never over what a data folder
keeps, whatever the name chosen (app.records.safewrite: a report saved from the window's
dialog under a trial file's name replaced the trial). The post-trial report
(app.reports.pdf) and the progress (app.reports.progress_pdf) go through it."""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from pathlib import Path

import matplotlib
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from app.errors import AppError
from app.records.safewrite import OutputRefused, atomic_output
from app.reports.pdf_sheet import RC
from device.safewrite import absolute


def write_pdf(path: str | os.PathLike, pages: Callable[[], Sequence[Figure]],
              metadata: dict[str, str], what: str, *, overwrite: bool = True) -> Path:
    """Draw `pages()` (under the report's RC) into the PDF at `path`, whose folder must
    exist; `what` names the file in an error ("the report"). An existing file is replaced
    only with `overwrite` (a report of the same trial, a name the therapist confirmed).
    Returns the path."""
    path = absolute(path)
    if not path.parent.is_dir():
        raise AppError(f"cannot write {what} {path}: the folder {path.parent} does not "
                       "exist. Create it or choose another place")
    try:
        # the fonts are embedded as TrueType at saving: RC holds while the pages are saved
        with matplotlib.rc_context(RC), atomic_output(path, overwrite=overwrite) as stream:
            drawn = pages()
            with PdfPages(stream, metadata={"Creator": "rehab-console", **metadata}) as pdf:
                for page in drawn:
                    pdf.savefig(page)
    except OutputRefused as exc:
        raise AppError(f"cannot write {what}: {exc}") from exc
    return path
