"""`artefacts.memo.by_file`: a whole-file reader runs once per file version, and callers never share
a result they could edit."""

import os

import h5py
import numpy as np

from legplan.artefacts.memo import by_file


def _write(path, value):
    tmp = path.with_suffix(".tmp")
    with h5py.File(tmp, "w") as f:
        f["x"] = np.array(value, float)
    os.replace(tmp, path)  # published like an artefact: a new inode


def test_a_file_is_read_once_per_version_and_results_are_copies(tmp_path):
    calls = []

    @by_file
    def reader(path):
        calls.append(path)
        if isinstance(path, h5py.File):
            return {"x": path["x"][()]}
        with h5py.File(path, "r") as f:
            return {"x": f["x"][()]}

    path = tmp_path / "a.h5"
    _write(path, [1.0, 2.0])
    first = reader(path)
    first["x"][0] = 99.0                     # a caller edits its copy
    second = reader(path)
    assert len(calls) == 1 and second["x"].tolist() == [1.0, 2.0]
    _write(path, [3.0])                      # published anew: read again
    assert reader(path)["x"].tolist() == [3.0] and len(calls) == 2
    with h5py.File(path, "r") as handle:     # an open handle is keyed by its file and group
        assert reader(handle)["x"].tolist() == [3.0]
    assert len(calls) == 3
