"""Atomic artefact writer.

An artefact is written to a temporary file beside its target and published (`legplan.artefacts.publish`)
only when the writing code finished without an exception and no SIGINT / SIGTERM arrived, so a
killed, interrupted or failing command leaves no partial file and never damages an existing good
one. Existing outputs are kept unless `overwrite` is set (checked early by `check_output`, and
again by the publishing rename itself).
"""

from __future__ import annotations

import os
import sys
from collections.abc import Iterable, Mapping
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from legplan import __version__
from legplan.artefacts.provenance import canonical_json, created_timestamp, input_record
from legplan.artefacts.publish import staged_output
from legplan.artefacts.schema import SCHEMA_VERSIONS
from legplan.errors import ArtefactError

SUMMARY_DTYPE = np.dtype([("name", h5py.string_dtype()), ("value", "f8"),
                          ("units", h5py.string_dtype())])


def check_output(path: str | os.PathLike, overwrite: bool) -> Path:
    """Fail early, before any work, when `path` exists and may not be replaced."""
    path = Path(path)
    if path.is_dir():
        raise ArtefactError(f"{path}: output is a directory")
    if path.exists() and not overwrite:
        raise ArtefactError(f"{path}: output exists (use --overwrite to replace it)")
    folder = path.parent if str(path.parent) else Path(".")
    if folder.is_dir() and not os.access(folder, os.W_OK | os.X_OK):
        raise ArtefactError(f"{path}: cannot write the output: folder {folder} is not writable")
    return path


@contextmanager
def write_artefact(path: str | os.PathLike, kind: str, *, params: Mapping | None = None,
                   seed: int | None = None, inputs: Iterable[str | os.PathLike] = (),
                   command: list[str] | None = None, overwrite: bool = False):
    """Open a new artefact of `kind` for writing; yields the `h5py.File` (root group).

    Root attributes (kind, schema version, legplan version, creation time, command, params, seed,
    inputs with sha256) are written first; the file appears at `path` only when the block ends
    without an exception.
    """
    if kind not in SCHEMA_VERSIONS:
        raise ValueError(f"unknown artefact kind {kind!r}")
    path = check_output(path, overwrite)
    records = [input_record(p) for p in inputs]
    with staged_output(path, overwrite=overwrite) as tmp, h5py.File(tmp, "w", track_order=True) as handle:
        attrs = handle.attrs
        attrs["legplan_kind"] = kind
        attrs["schema_version"] = SCHEMA_VERSIONS[kind]
        attrs["legplan_version"] = __version__
        attrs["created"] = created_timestamp()
        attrs["command"] = canonical_json(["legplan", *sys.argv[1:]] if command is None else list(command))
        attrs["params"] = canonical_json(dict(params or {}))
        attrs["seed"] = -1 if seed is None else int(seed)
        attrs["inputs"] = canonical_json(records)
        yield handle


def write_dataset(group: h5py.Group, name: str, data, *, units: str | None = None,
                  **attrs) -> h5py.Dataset:
    """Write an array with its SI `units` attribute (and any other attributes)."""
    array = np.asarray(data)
    options = {"compression": "gzip", "compression_opts": 4} if array.size >= 4096 else {}
    dataset = group.create_dataset(name, data=array, track_times=False, **options)
    if units is not None:
        dataset.attrs["units"] = units
    for key, value in attrs.items():
        dataset.attrs[key] = value
    return dataset


def write_summary(handle: h5py.File, metrics: Mapping[str, float | tuple[float, str]]) -> None:
    """Write the `/summary` table: one row per metric, `value` or `(value, units)`."""
    rows = []
    for name, entry in metrics.items():
        value, units = entry if isinstance(entry, tuple) else (entry, "")
        rows.append((name, float(value), units))
    handle.create_dataset("summary", data=np.array(rows, dtype=SUMMARY_DTYPE), track_times=False)
