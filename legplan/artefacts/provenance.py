"""Provenance of an artefact: what it was made from, by which command, with which parameters.

`inputs` records each input file's path, sha256 and kind, so a pipeline can tell whether an output
is up to date by content rather than by timestamp.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import os
from contextlib import contextmanager
from pathlib import Path

import h5py

from legplan.errors import ArtefactError

_CHUNK = 1 << 20


def sha256_file(path: str | os.PathLike) -> str:
    """Hex sha256 digest of a file's bytes."""
    digest = hashlib.sha256()
    try:
        with open(path, "rb") as stream:
            for chunk in iter(lambda: stream.read(_CHUNK), b""):
                digest.update(chunk)
    except OSError as exc:
        raise ArtefactError(f"{path}: cannot read input ({exc.strerror or exc})") from exc
    return digest.hexdigest()


def file_kind(path: str | os.PathLike) -> str:
    """The `legplan_kind` of an artefact, or the file suffix (e.g. `yaml`) for any other file."""
    path = Path(path)
    if h5py.is_hdf5(path):
        try:
            with h5py.File(path, "r") as handle:
                kind = handle.attrs.get("legplan_kind")
        except OSError:
            kind = None
        if kind is not None:
            return str(kind)
        return "hdf5"
    return path.suffix.lstrip(".") or "file"


_RECORDS: dict[tuple, dict] | None = None  # inside `inputs_read_once`


@contextmanager
def inputs_read_once():
    """Within the block, `input_record` reads and hashes each input file once and reuses its record
    while the file is the same one, unchanged (device, inode, size, modification and change times): a
    stage records its inputs twice (its work file, its artefact) in one command."""
    global _RECORDS
    saved, _RECORDS = _RECORDS, {}
    try:
        yield
    finally:
        _RECORDS = saved


def input_record(path: str | os.PathLike) -> dict:
    """`{path, sha256, kind}` for one input file; a map also its `terrain` digest
    (`legplan.artefacts.identity.terrain_digest`), the identity later pairs are checked against."""
    key = None
    if _RECORDS is not None:
        try:
            status = os.stat(path)
            key = (str(path), status.st_dev, status.st_ino, status.st_size, status.st_mtime_ns, status.st_ctime_ns)
        except OSError:
            pass  # sha256_file says what is wrong with it
        if key in _RECORDS:
            return dict(_RECORDS[key])
    record = {"path": str(path), "sha256": sha256_file(path), "kind": file_kind(path)}
    if record["kind"] == "map" and h5py.is_hdf5(path):  # a map artefact (a MovingAI .map is text)
        from legplan.artefacts.identity import terrain_digest

        record["terrain"] = terrain_digest(path)
    if key is not None:
        _RECORDS[key] = dict(record)
    return record


def created_timestamp() -> str:
    """ISO 8601 UTC time of creation; `SOURCE_DATE_EPOCH` pins it for byte-reproducible artefacts."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    moment = (_dt.datetime.fromtimestamp(int(epoch), _dt.timezone.utc) if epoch
              else _dt.datetime.now(_dt.timezone.utc))
    return moment.replace(microsecond=0).isoformat()


def canonical_json(value) -> str:
    """JSON with sorted keys and no whitespace variation, so equal params give equal strings."""
    return json.dumps(value, sort_keys=True, separators=(",", ":"), default=_json_default)


def _json_default(value):
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")
