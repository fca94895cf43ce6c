"""Validating artefact reader: one error type (`ArtefactError`) whose message names the file.

`open_artefact` is the one door of every reader: before a caller sees the file it checks the kind, the
schema and that every float dataset holds finite values (but where `schema.NAN_MEANS_NONE` says NaN
means "none"), so no command ever draws, reports, trains on or executes a NaN it did not write."""

from __future__ import annotations

import fnmatch
import json
import os
from contextlib import contextmanager
from pathlib import Path

import h5py
import numpy as np

from legplan.artefacts.schema import NAN_MEANS_NONE, ROOT_ATTRS, SCHEMA_VERSIONS
from legplan.errors import ArtefactError


@contextmanager
def open_artefact(path: str | os.PathLike, kind: str | tuple[str, ...] | None = None, *, values: bool = True):
    """Open an artefact read-only after checking it is a legplan file of `kind` and known schema and,
    with `values`, that its float datasets are finite (module docstring). `values=False` is for a
    reader that reads every dataset it uses through `read_array` (finite) anyway, or none: it saves
    reading a large file twice."""
    path = Path(path)
    if not path.exists():
        raise ArtefactError(f"{path}: no such file")
    if not path.is_file():
        raise ArtefactError(f"{path}: not a file")
    if not h5py.is_hdf5(path):
        raise ArtefactError(f"{path}: not an HDF5 file")
    try:
        handle = h5py.File(path, "r")
    except OSError as exc:
        raise ArtefactError(f"{path}: truncated or corrupt HDF5 file ({exc})") from exc
    with handle:
        _validate_root(path, handle, kind)
        if values:
            _validate_values(path, handle)
        yield handle


def _validate_root(path: Path, handle: h5py.File, kind) -> None:
    try:
        actual = handle.attrs.get("legplan_kind")
        version = handle.attrs.get("schema_version")
    except OSError as exc:
        raise ArtefactError(f"{path}: corrupt HDF5 attributes ({exc})") from exc
    if actual is None:
        raise ArtefactError(f"{path}: not a legplan artefact (no 'legplan_kind' attribute)")
    actual = str(actual)
    wanted = (kind,) if isinstance(kind, str) else kind
    if wanted is not None and actual not in wanted:
        raise ArtefactError(f"{path}: is a '{actual}' artefact, expected '{' or '.join(wanted)}'")
    if actual not in SCHEMA_VERSIONS:
        raise ArtefactError(f"{path}: unknown artefact kind '{actual}'")
    if version is None:
        raise ArtefactError(f"{path}: missing attribute 'schema_version'")
    if int(version) > SCHEMA_VERSIONS[actual]:
        raise ArtefactError(f"{path}: '{actual}' schema version {int(version)} is newer than this "
                            f"legplan reads ({SCHEMA_VERSIONS[actual]}); upgrade legplan")
    missing = [name for name in ROOT_ATTRS if name not in handle.attrs]
    if missing:
        raise ArtefactError(f"{path}: missing root attribute '{missing[0]}'")


_CHECKED: set[tuple] = set()  # files whose values were checked, by identity and modification


def _validate_values(path: Path, handle: h5py.File) -> None:
    """An `ArtefactError` naming the first float dataset with a NaN or inf that its kind does not
    allow (`schema.NAN_MEANS_NONE`); each file version is checked once per process."""
    stat = path.stat()
    key = (stat.st_dev, stat.st_ino, stat.st_size, stat.st_mtime_ns)
    if key in _CHECKED:
        return
    excused = NAN_MEANS_NONE.get(str(handle.attrs["legplan_kind"]), {})
    datasets = []
    handle.visititems(lambda name, node: datasets.append(name)
                      if isinstance(node, h5py.Dataset) and node.dtype.kind in "fc" else None)
    for name in datasets:
        rule = next((mask for pattern, mask in excused.items() if fnmatch.fnmatchcase(name, pattern)), ...)
        if rule is None:
            continue
        dataset = handle[name]
        where = f"{path}: dataset '/{name}'"
        try:
            values = np.asarray(dataset[()])
        except (OSError, ValueError, TypeError) as exc:
            raise ArtefactError(f"{where} cannot be read ({' '.join(str(exc).split())})") from None
        if rule is not ...:  # excused in the rows where the mask is false
            mask = np.asarray(require(handle, rule)[()], bool).reshape(-1)
            if values.ndim and mask.size == len(values):
                values = values[mask]
        check_finite(where, values)
    _CHECKED.add(key)


def require(handle: h5py.File | h5py.Group, name: str):
    """The dataset or group `name`, or an `ArtefactError` naming the file and the missing item."""
    try:
        return handle[name]
    except KeyError:
        where = handle.file.filename
        raise ArtefactError(f"{where}: missing dataset '{handle.name.rstrip('/')}/{name}'") from None
    except OSError as exc:
        raise ArtefactError(f"{handle.file.filename}: cannot read '{name}' ({exc})") from exc


def require_attrs(group: h5py.File | h5py.Group, names) -> dict:
    """Every attribute of `group` as a dict, or an `ArtefactError` naming the file, the group and
    the first of `names` it lacks (a reader's check that what its consumers index is there)."""
    attrs = dict(group.attrs)
    missing = [name for name in names if name not in attrs]
    if missing:
        raise ArtefactError(f"{group.file.filename}: group '{group.name}' lacks attribute '{missing[0]}'")
    return attrs


def read_array(handle: h5py.File | h5py.Group, name: str, *, ndim: int | None = None,
               finite: bool = True) -> np.ndarray:
    """The array of dataset `name`, checked at the boundary: readable (a truncated file fails here,
    naming it), `ndim` dimensions when given, and every value finite when `finite` (floats only).
    Any failure is an `ArtefactError` naming the file and the dataset."""
    dataset = require(handle, name)
    where = f"{handle.file.filename}: dataset '{dataset.name}'"
    if not isinstance(dataset, h5py.Dataset):
        raise ArtefactError(f"{where} is a group, expected a dataset")
    try:
        array = np.asarray(dataset[()])
    except (OSError, ValueError, TypeError) as exc:
        raise ArtefactError(f"{where} cannot be read ({' '.join(str(exc).split())})") from None
    if ndim is not None and array.ndim != ndim:
        raise ArtefactError(f"{where} must have {ndim} dimension(s), got shape {array.shape}")
    if finite:
        check_finite(where, array)
    return array


def check_finite(where: str, array: np.ndarray) -> None:
    """An `ArtefactError` "WHERE holds NaN or inf (first at index ...)" unless every value of a
    numeric `array` is finite (non-float arrays pass)."""
    if array.dtype.kind not in "fc":
        return
    bad = ~np.isfinite(array)
    if bad.any():
        index = tuple(int(i) for i in np.argwhere(bad)[0])
        raise ArtefactError(f"{where} holds NaN or inf (first at index {index if len(index) != 1 else index[0]})")


def read_provenance(handle: h5py.File) -> dict:
    """Root attributes with JSON fields decoded."""
    attrs = handle.attrs
    return {
        "kind": str(attrs["legplan_kind"]),
        "schema_version": int(attrs["schema_version"]),
        "legplan_version": str(attrs["legplan_version"]),
        "created": str(attrs["created"]),
        "command": json.loads(attrs["command"]),
        "params": json.loads(attrs["params"]),
        "seed": None if int(attrs["seed"]) < 0 else int(attrs["seed"]),
        "inputs": json.loads(attrs["inputs"]),
    }


def read_summary(handle: h5py.File) -> dict[str, tuple[float, str]]:
    """`/summary` as `{name: (value, units)}`; empty when the artefact has none."""
    if "summary" not in handle:
        return {}
    rows = require(handle, "summary")[()]
    return {_text(row["name"]): (float(row["value"]), _text(row["units"])) for row in rows}


def _text(value) -> str:
    return value.decode() if isinstance(value, bytes) else str(value)
