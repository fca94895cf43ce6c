"""The work file of a batch: `<output>.work` beside the output, one HDF5 group per finished item.

Root attributes: `legplan_work` (format version), `identity` (JSON: the stage and its parameters,
as given by the caller), `inputs` (JSON list of `{path, sha256, kind}`), `items` (sha256 of the
pickled items) and `count`. Group `/items/NNNNNN` (the item's position in the batch) holds its
record: nested dicts become groups, numpy arrays datasets, scalars and strings attributes, and
`__keys__` (JSON) keeps the record's key order, so a record read back is the record written up to
numpy scalar types. The file is flushed after every item, so a killed run keeps what had finished;
`--resume` continues it only when identity, inputs and items all match.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
from collections.abc import Mapping, Sequence
from pathlib import Path

import h5py
import numpy as np

from legplan.artefacts.provenance import canonical_json, input_record
from legplan.errors import LegplanError

FORMAT = 1
SCALARS = (str, bool, int, float, np.generic)


def work_path(output: str | os.PathLike) -> Path:
    """`<output>.work`, beside the output."""
    output = Path(output)
    return output.with_name(output.name + ".work")


def items_digest(items: Sequence) -> str:
    """sha256 of the pickled items (same items in the same order, same digest)."""
    return hashlib.sha256(pickle.dumps(list(items), protocol=4)).hexdigest()


def write_record(group: h5py.Group, record: Mapping) -> None:
    """Store a record (str keys; values dicts, numpy arrays, numbers, bools or strings) in `group`."""
    for key, value in record.items():
        if isinstance(value, Mapping):
            write_record(group.create_group(key, track_order=True), value)
        elif isinstance(value, np.ndarray):
            group.create_dataset(key, data=value, track_times=False)
        elif isinstance(value, SCALARS):
            group.attrs[key] = value
        else:
            raise TypeError(f"record field {key!r}: cannot store {type(value).__name__} "
                            "(use a dict, a numpy array, a number, a bool or a string)")
    group.attrs["__keys__"] = json.dumps(list(record))


def read_record(group: h5py.Group) -> dict:
    """The record `write_record` stored in `group`, keys in their original order."""
    values = {}
    for key in json.loads(group.attrs["__keys__"]):
        if key in group:
            node = group[key]
            values[key] = read_record(node) if isinstance(node, h5py.Group) else node[()]
        else:
            values[key] = group.attrs[key]
    return values


class WorkFile:
    """The open work file of one batch; `add` stores a finished item, `records` reads them all."""

    def __init__(self, path: Path, handle: h5py.File):
        self.path = path
        self.handle = handle
        self.items = handle.require_group("items")
        self.inode = path.stat().st_ino

    @classmethod
    def open(cls, output, identity: Mapping, inputs: Sequence, items: Sequence, *, resume: bool,
             overwrite: bool) -> WorkFile:
        """Start `<output>.work`, or continue it with `resume` when it was started for the same
        identity, inputs and items. An existing work file without `resume` is an error unless
        `overwrite` (which starts over)."""
        path = work_path(output)
        header = {"legplan_work": FORMAT, "identity": canonical_json(dict(identity)),
                  "inputs": canonical_json([input_record(p) for p in inputs]),
                  "items": items_digest(items), "count": len(items)}
        if path.exists() and resume:
            handle = _open_existing(path)
            mismatch = _mismatch(handle.attrs, header)
            if mismatch:
                handle.close()
                raise LegplanError(f"{path}: --resume refused, this work file was started with {mismatch}; "
                                   f"delete it or use --overwrite to start over")
            for name in [name for name, group in handle["items"].items() if "__keys__" not in group.attrs]:
                del handle["items"][name]  # cut short by a kill while it was written
            return cls(path, handle)
        if path.exists() and not overwrite:
            raise LegplanError(f"{path}: work file of an interrupted run exists; --resume continues it, "
                               f"--overwrite starts over")
        # a new file, never the old one truncated: a concurrent run of the same output (--overwrite)
        # keeps writing its own, now unlinked, work file and publishes after or before this one
        for attempt in range(3):
            path.unlink(missing_ok=True)
            try:
                handle = h5py.File(path, "x", track_order=True)
                break
            except FileExistsError:  # a concurrent run created it in between: replace that one
                if attempt == 2:
                    raise LegplanError(f"{path}: other runs of this output keep starting; run one at a time") from None
            except OSError as exc:  # e.g. a read-only folder: say so for the user's output
                reason = os.strerror(exc.errno) if exc.errno else "cannot create it"
                raise LegplanError(f"{output}: cannot write the output in {path.parent} ({reason})") from None
        handle.attrs.update(header)
        handle.flush()
        return cls(path, handle)

    def done(self) -> set[int]:
        """Positions of the items already stored."""
        return {int(name) for name in self.items}

    def add(self, position: int, record: Mapping) -> None:
        """Store one finished item and flush, so a killed process keeps it."""
        write_record(self.items.create_group(f"{position:06d}", track_order=True), record)
        self.handle.flush()

    def records(self) -> list[dict]:
        """Every stored record in item order."""
        return [read_record(self.items[name]) for name in sorted(self.items)]

    def record(self, position: int) -> dict:
        """The stored record of the item at `position`."""
        return read_record(self.items[f"{position:06d}"])

    def close(self) -> None:
        if self.handle.id.valid:
            self.handle.close()

    def remove(self) -> None:
        """Close and delete the work file, unless another run has replaced it at the same path."""
        self.close()
        try:
            if self.path.stat().st_ino == self.inode:
                self.path.unlink()
        except FileNotFoundError:
            pass


def _open_existing(path: Path) -> h5py.File:
    try:
        handle = h5py.File(path, "a")
    except OSError as exc:
        raise LegplanError(f"{path}: cannot read the work file ({exc}); delete it to start over") from None
    if handle.attrs.get("legplan_work") != FORMAT:
        handle.close()
        raise LegplanError(f"{path}: not a legplan work file of format {FORMAT}; delete it to start over")
    return handle


def _mismatch(attrs, header: dict) -> str:
    """What differs between a stored work file header and this batch's ('' when nothing)."""
    if attrs["identity"] != header["identity"]:
        return f"other parameters ({attrs['identity']} vs now {header['identity']})"
    stored = {(r["kind"], r["sha256"]) for r in json.loads(attrs["inputs"])}
    now = json.loads(header["inputs"])
    changed = [r["path"] for r in now if (r["kind"], r["sha256"]) not in stored]
    if changed or len(stored) != len(now):
        return f"other inputs ({', '.join(changed) or 'a different number of files'} differ)"
    if attrs["items"] != header["items"] or int(attrs["count"]) != header["count"]:
        return f"other items ({int(attrs['count'])} items then, {header['count']} now, or different ones)"
    return ""
