"""Finding an artefact's recorded inputs again when the report runs elsewhere.

Provenance records each input's path as it was given, so a relative path means "relative to the
directory the producing command ran in", which the report does not know. `recorded_input` tries the
recorded path from here, then from the artefact's directory and each of its parents (the producing
command usually ran in one of them), then the file name beside the artefact, and accepts the first
candidate whose sha256 equals the recorded one.
"""

from __future__ import annotations

import os
from functools import lru_cache
from pathlib import Path

from legplan.artefacts import open_artefact, read_provenance, sha256_file
from legplan.errors import ArtefactError


def recorded_input(path: str | os.PathLike, kind: str) -> Path | None:
    """The first input of `kind` recorded by artefact `path`, found by content (see module doc);
    None when the artefact records no input of that kind. `ArtefactError` when it records one that
    cannot be found with the recorded sha256."""
    path = Path(path)
    with open_artefact(path) as handle:
        record = next((r for r in read_provenance(handle)["inputs"] if r["kind"] == kind), None)
    if record is None:
        return None
    recorded = Path(record["path"])
    candidates = [recorded] if recorded.is_absolute() else \
        [recorded, *(parent / recorded for parent in path.resolve().parents)]
    candidates.append(path.parent / recorded.name)
    existing = [c for c in dict.fromkeys(candidates) if c.is_file()]
    for candidate in existing:
        if _sha256(str(candidate.resolve()), *_stamp(candidate)) == record["sha256"]:
            return candidate
    found = f"; {existing[0]} has other content (sha256 differs)" if existing else ""
    raise ArtefactError(f"{path}: input {kind} '{recorded}' not found from here, beside the artefact "
                        f"or in its parent directories{found}")


def _stamp(path: Path) -> tuple[int, int]:
    status = path.stat()
    return status.st_mtime_ns, status.st_size


@lru_cache(maxsize=32)
def _sha256(path: str, mtime_ns: int, size: int) -> str:
    """sha256 of a file, cached by path, modification time and size (several figures read one map)."""
    return sha256_file(path)
