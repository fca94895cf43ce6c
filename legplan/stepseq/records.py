"""Step-sequence files (CSV, JSON, YAML, HDF5) as lists of flat records, one per configuration.

A record maps field names to values (see README, "Step-sequence files"):
  x, y, z                      base position (m)
  qx, qy, qz, qw | roll, pitch, yaw   base orientation: quaternion or RPY (rad, R = Rz Ry Rx)
  <joint name> ...             joint angles (rad) by name, or
  joints: [...] / j0, j1, ...  joint angles in URDF order
  stance_<leg>                 1/0, true/false
  foothold_<leg>_x/_y/_z       optional explicit foothold (m); empty/NaN for swing legs
JSON/YAML files hold {"configurations": [record, ...]} (a bare list is refused); a record may also give
"footholds": {leg: [x, y, z]}. HDF5: a group /configurations with one 1-D dataset per field, or a
legplan steps.h5 artefact.
"""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import h5py
import numpy as np
import yaml

from legplan.artefacts.publish import staged_output
from legplan.errors import SpecError
from legplan.specio import read_csv_table, read_text

FORMATS = {".csv": "csv", ".json": "json", ".yaml": "yaml", ".yml": "yaml", ".h5": "hdf5",
           ".hdf5": "hdf5"}


def file_format(path) -> str:
    """The format of `path` from its suffix, or SpecError."""
    suffix = Path(path).suffix.lower()
    if suffix not in FORMATS:
        raise SpecError(f"{path}: unknown step-sequence format '{suffix}' "
                        f"(expected one of {', '.join(sorted(FORMATS))})")
    return FORMATS[suffix]


def read_records(path) -> list[dict]:
    """Read a step-sequence file into records (field -> value); SpecError on unreadable files."""
    path = Path(path)
    fmt = file_format(path)
    if not path.is_file():
        raise SpecError(f"{path}: no such file")
    if fmt == "csv":
        return _read_csv(path)
    if fmt == "hdf5":
        return _read_hdf5(path)
    text = read_text(path, f"{fmt.upper()} step-sequence file")
    try:
        data = json.loads(text) if fmt == "json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError, ValueError, RecursionError) as exc:
        raise SpecError(f"{path}: not valid {fmt.upper()} ({exc})".replace("\n", " ")) from None
    if not isinstance(data, dict):
        raise SpecError(f"{path}: must be a mapping with the field 'configurations' (a list of mappings), "
                        f"got a {'list' if isinstance(data, list) else type(data).__name__}")
    if "configurations" not in data:
        raise SpecError(f"{path}: field 'configurations' is missing")
    data = data["configurations"]
    if not isinstance(data, list) or not all(isinstance(r, dict) for r in data):
        raise SpecError(f"{path}: field 'configurations' must be a list of mappings")
    return [_flatten_footholds(path, i, dict(r)) for i, r in enumerate(data)]


def _flatten_footholds(path, row: int, record: dict) -> dict:
    footholds = record.pop("footholds", None)
    if footholds is None:
        return record
    if not isinstance(footholds, dict):
        raise SpecError(f"{path}: row {row}: field 'footholds' must map leg names to [x, y, z]")
    for leg, point in footholds.items():
        if point is None:
            continue
        if not isinstance(point, (list, tuple)) or len(point) != 3:
            raise SpecError(f"{path}: row {row}: field 'footholds.{leg}' must be [x, y, z]")
        for axis, value in zip("xyz", point, strict=True):
            record[f"foothold_{leg}_{axis}"] = value
    return record


def _read_csv(path: Path) -> list[dict]:
    header, rows = read_csv_table(path, "CSV step-sequence file")
    return [{h: v.strip() for h, v in zip(header, row, strict=True) if v.strip() != ""} for row in rows]


def _read_hdf5(path: Path) -> list[dict]:
    if not h5py.is_hdf5(path):
        raise SpecError(f"{path}: not an HDF5 file")
    try:
        with h5py.File(path, "r") as f:
            if "legplan_kind" in f.attrs:
                return _records_from_steps(path)
            if not isinstance(f.get("configurations"), h5py.Group):
                raise SpecError(f"{path}: group '/configurations' is missing")
            group = f["configurations"]
            odd = [name for name, item in group.items() if not isinstance(item, h5py.Dataset)]
            if odd:
                raise SpecError(f"{path}: '/configurations/{odd[0]}' must be a 1-D dataset, not a group")
            columns = {name: np.asarray(ds[()]).reshape(-1) for name, ds in group.items()}
    except OSError as exc:
        raise SpecError(f"{path}: truncated or corrupt HDF5 file ({' '.join(str(exc).split())})") from None
    lengths = {len(v) for v in columns.values()}
    if len(lengths) > 1:
        raise SpecError(f"{path}: datasets under '/configurations' differ in length {sorted(lengths)}")
    k = lengths.pop() if lengths else 0
    return [{name: col[i].item() for name, col in columns.items()} for i in range(k)]


def _records_from_steps(path: Path) -> list[dict]:
    from legplan.stepseq.sequence import read_steps
    return sequence_records(read_steps(path))


def sequence_records(seq) -> list[dict]:
    """Records (quaternion orientation, joints by name, explicit footholds) of a `StepSequence`."""
    records = []
    for q, stance, footholds in zip(seq.q, seq.stance, seq.footholds, strict=True):
        r = dict(zip(("x", "y", "z", "qx", "qy", "qz", "qw"), map(float, q[:7]), strict=True))
        r.update(zip(seq.joint_names, map(float, q[7:]), strict=True))
        for leg, on, point in zip(seq.leg_names, stance, footholds, strict=True):
            r[f"stance_{leg}"] = int(on)
            for axis, value in zip("xyz", point, strict=True):
                r[f"foothold_{leg}_{axis}"] = float(value) if on else math.nan
        records.append(r)
    return records


def write_records(path, seq, *, overwrite: bool = False) -> None:
    """Export a `StepSequence` as CSV, JSON or YAML (format from the suffix); exact float text.
    Published like any output (`legplan.artefacts.publish`)."""
    path = Path(path)
    fmt = file_format(path)
    records = sequence_records(seq)
    if fmt == "csv":
        header = list(records[0]) if records else []
        with staged_output(path, overwrite=overwrite) as temp, temp.open("w", newline="") as handle:
            writer = csv.writer(handle)
            writer.writerow(header)
            for r in records:
                writer.writerow(["" if isinstance(v, float) and math.isnan(v) else repr(v)
                                 for v in r.values()])
        return
    if fmt == "hdf5":
        raise SpecError(f"{path}: export writes CSV, JSON or YAML; steps.h5 already is the HDF5 form")
    nested = []
    for r in records:
        out = {k: v for k, v in r.items() if not k.startswith("foothold_")}
        out["footholds"] = {leg: [r[f"foothold_{leg}_{a}"] for a in "xyz"]
                            for leg, on in zip(seq.leg_names, (r[f"stance_{leg}"] for leg in seq.leg_names),
                                               strict=True) if on}
        nested.append(out)
    doc = {"robot": seq.robot, "configurations": nested}
    text = json.dumps(doc, indent=1) if fmt == "json" else yaml.safe_dump(doc, sort_keys=False)
    with staged_output(path, overwrite=overwrite) as temp:
        temp.write_text(text)
