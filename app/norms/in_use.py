"""The norms a data folder uses: the file chosen with `rehab norms use` (kept in the data
folder, `models/norms/in-use.json`, a verified copy), else the console's shipped simulated
norms (resources/norms/simulated.json, labelled simulated on every report), else none.

Choosing other norms never loses the ones before: the file in use is moved aside as
`models/norms/replaced-<UTC stamp>-<hash>.json` first.
"""

from __future__ import annotations

import json
import os
from datetime import UTC, datetime
from pathlib import Path

from app.norms.model import NormativeModel
from app.norms.modelfile import load_norms, norms_document, parse_norms

IN_USE = "in-use.json"
SHIPPED = Path(__file__).resolve().parents[2] / "resources" / "norms" / "simulated.json"


def norms_folder(data_dir) -> Path:
    return data_dir.models_dir / "norms"


def norms_in_use(data_dir, shipped: Path | None = None) -> NormativeModel | None:
    """The data folder's norms (verified; a damaged file is refused in one line, never
    replaced by the shipped ones in silence), else the shipped simulated norms, else None."""
    chosen = norms_folder(data_dir) / IN_USE
    if chosen.exists():
        return load_norms(chosen)
    shipped = SHIPPED if shipped is None else shipped
    if shipped.is_file():
        return load_norms(shipped)
    return None


def use_norms(data_dir, source: str | os.PathLike) -> tuple[NormativeModel, Path | None]:
    """Verify `source` and make it the data folder's norms; returns the model and where the
    norms used before were moved (None when there were none)."""
    from app.records.safewrite import write_text

    model = load_norms(source)
    document = norms_document(json.loads(Path(source).read_text(encoding="utf-8")))
    parse_norms(document, source)
    folder = data_dir.ensure("models", "norms")
    target = folder / IN_USE
    text = json.dumps(document, indent=1, allow_nan=False) + "\n"
    moved = None
    if os.path.lexists(target):
        # the norms in use are copied aside first and replaced in one atomic step after:
        # a failure between leaves them in use, never no norms (which would fall back to
        # the shipped simulated ones)
        stamp = datetime.now(UTC).strftime("%Y%m%dT%H%M%SZ")
        stem = f"replaced-{stamp}-{_hash_of(target)[:12]}"
        moved = folder / f"{stem}.json"
        number = 1
        while os.path.lexists(moved):
            number += 1
            moved = folder / f"{stem}-{number}.json"
        write_bytes_new(moved, target.read_bytes())
    write_text(target, text, overwrite=True, owned=True)
    return model, moved


def write_bytes_new(path: Path, data: bytes) -> None:
    from app.records.safewrite import atomic_output

    with atomic_output(path, owned=True) as stream:
        stream.write(data)


def _hash_of(path: Path) -> str:
    """The file's content_sha256 as it says, for the name it is kept under when replaced
    (a damaged file is kept too, named so)."""
    try:
        stated = json.loads(path.read_text(encoding="utf-8")).get("content_sha256")
    except (OSError, ValueError, AttributeError, RecursionError):
        return "unreadable"
    return stated if isinstance(stated, str) and stated.isalnum() else "unhashed"
