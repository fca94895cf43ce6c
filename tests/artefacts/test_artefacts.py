"""Artefact layer: atomic writes, provenance attributes, validating reader."""

import json
import os

import h5py
import numpy as np
import pytest

from legplan import __version__
from legplan.artefacts import (check_output, open_artefact, read_provenance, read_summary,
                               require, sha256_file, write_artefact, write_dataset, write_summary)
from legplan.errors import ArtefactError


def _write_map(path, value=1.0, **kwargs):
    with write_artefact(path, "map", **kwargs) as handle:
        write_dataset(handle, "terrain/height", np.full((3, 4), value), units="m")
        write_summary(handle, {"cells": 12, "max_height": (value, "m")})


def test_round_trip_keeps_data_units_and_summary(tmp_path):
    path = tmp_path / "map.h5"
    _write_map(path, 2.5, params={"resolution": 0.02}, seed=7)
    with open_artefact(path, kind="map") as handle:
        height = require(handle, "terrain/height")
        assert height.attrs["units"] == "m"
        np.testing.assert_array_equal(height[()], np.full((3, 4), 2.5))
        assert read_summary(handle) == {"cells": (12.0, ""), "max_height": (2.5, "m")}


def test_provenance_records_inputs_with_sha256(tmp_path, monkeypatch):
    spec = tmp_path / "spec.yaml"
    spec.write_text("resolution: 0.02\n")
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "0")
    path = tmp_path / "map.h5"
    _write_map(path, params={"b": 1, "a": [1, 2]}, seed=3, inputs=[spec],
               command=["legplan", "map", "build"])
    with open_artefact(path) as handle:
        prov = read_provenance(handle)
    assert prov["kind"] == "map" and prov["schema_version"] == 1
    assert prov["legplan_version"] == __version__
    assert prov["created"] == "1970-01-01T00:00:00+00:00"
    assert prov["command"] == ["legplan", "map", "build"]
    assert prov["params"] == {"a": [1, 2], "b": 1}
    assert prov["seed"] == 3
    assert prov["inputs"] == [{"path": str(spec), "sha256": sha256_file(spec), "kind": "yaml"}]


def test_same_inputs_give_byte_identical_artefacts(tmp_path, monkeypatch):
    monkeypatch.setenv("SOURCE_DATE_EPOCH", "1700000000")
    for name in ("a.h5", "b.h5"):
        _write_map(tmp_path / name, params={"x": 1}, seed=1, command=["legplan"])
    assert sha256_file(tmp_path / "a.h5") == sha256_file(tmp_path / "b.h5")


def test_artefact_permissions_follow_umask(tmp_path):
    old = os.umask(0o022)
    try:
        _write_map(tmp_path / "map.h5")
    finally:
        os.umask(old)
    assert (tmp_path / "map.h5").stat().st_mode & 0o777 == 0o644


def test_failure_mid_write_leaves_no_file(tmp_path):
    path = tmp_path / "map.h5"
    with pytest.raises(RuntimeError):
        with write_artefact(path, "map") as handle:
            write_dataset(handle, "x", np.zeros(10))
            raise RuntimeError("planner crashed")
    assert list(tmp_path.iterdir()) == []


def test_failure_mid_overwrite_keeps_prior_file_intact(tmp_path):
    path = tmp_path / "map.h5"
    _write_map(path, 1.0)
    before = sha256_file(path)
    with pytest.raises(RuntimeError):
        with write_artefact(path, "map", overwrite=True) as handle:
            write_dataset(handle, "terrain/height", np.zeros(3))
            raise RuntimeError("killed")
    assert sha256_file(path) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.h5"]


def test_existing_output_is_refused_without_overwrite(tmp_path):
    path = tmp_path / "map.h5"
    _write_map(path)
    with pytest.raises(ArtefactError, match="exists.*--overwrite"):
        _write_map(path)
    with pytest.raises(ArtefactError, match="output exists"):
        check_output(path, overwrite=False)
    _write_map(path, 9.0, overwrite=True)
    with open_artefact(path) as handle:
        assert handle["terrain/height"][0, 0] == 9.0


@pytest.mark.parametrize("content, message", [
    (b"hello\n", "not an HDF5 file"),
    (os.urandom(4096), "not an HDF5 file"),
])
def test_reader_refuses_non_hdf5(tmp_path, content, message):
    path = tmp_path / "bad.h5"
    path.write_bytes(content)
    with pytest.raises(ArtefactError, match=f"{path}: {message}"):
        with open_artefact(path):
            pass


def test_reader_refuses_truncated_file(tmp_path):
    path = tmp_path / "map.h5"
    _write_map(path)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(ArtefactError, match="map.h5: (truncated or corrupt|corrupt)"):
        with open_artefact(path) as handle:
            require(handle, "terrain/height")[()]


def test_reader_checks_kind_schema_and_datasets(tmp_path):
    path = tmp_path / "map.h5"
    _write_map(path)
    with pytest.raises(ArtefactError, match="is a 'map' artefact, expected 'nav'"):
        with open_artefact(path, kind="nav"):
            pass
    with open_artefact(path, kind=("nav", "map")) as handle:
        with pytest.raises(ArtefactError, match="missing dataset '/terrain/sdf'"):
            require(handle, "terrain/sdf")
    with h5py.File(path, "a") as handle:
        handle.attrs["schema_version"] = 99
    with pytest.raises(ArtefactError, match="schema version 99 is newer"):
        with open_artefact(path):
            pass


def test_reader_refuses_plain_hdf5_and_missing_paths(tmp_path):
    plain = tmp_path / "plain.h5"
    with h5py.File(plain, "w") as handle:
        handle["x"] = 1
    with pytest.raises(ArtefactError, match="not a legplan artefact"):
        with open_artefact(plain):
            pass
    with pytest.raises(ArtefactError, match="no such file"):
        with open_artefact(tmp_path / "missing.h5"):
            pass
    with pytest.raises(ArtefactError, match="not a file"):
        with open_artefact(tmp_path):
            pass


def test_params_are_canonical_json(tmp_path):
    path = tmp_path / "map.h5"
    _write_map(path, params={"z": np.float64(0.5), "a": np.arange(2)})
    with h5py.File(path) as handle:
        assert json.loads(handle.attrs["params"]) == {"a": [0, 1], "z": 0.5}
        assert handle.attrs["params"] == '{"a":[0,1],"z":0.5}'
