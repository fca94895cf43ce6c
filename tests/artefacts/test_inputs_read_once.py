"""`inputs_read_once`: inside the block an unchanged input is read and hashed once; a changed or
replaced file, or any call outside the block, is read again."""

import os

import numpy as np
import pytest

from legplan.artefacts import provenance
from legplan.artefacts.provenance import input_record, inputs_read_once
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap


@pytest.fixture
def reads(monkeypatch):
    """The paths `sha256_file` was asked to hash."""
    seen = []
    original = provenance.sha256_file

    def counting(path):
        seen.append(str(path))
        return original(path)

    monkeypatch.setattr(provenance, "sha256_file", counting)
    return seen


def _map(path, height=0.0):
    grid = Grid2D(origin=(0.0, 0.0), resolution=0.1, shape=(5, 6))
    save_map(terrain_from_heightmap(np.full(grid.shape, height), grid, name="m"), path, overwrite=True)


def test_unchanged_input_is_hashed_once(tmp_path, reads):
    path = tmp_path / "map.h5"
    _map(path)
    with inputs_read_once():
        first, second = input_record(path), input_record(path)
    assert first == second and first["kind"] == "map" and "terrain" in first
    assert reads == [str(path)]
    second["sha256"] = "changed by the caller"
    with inputs_read_once():
        assert input_record(path) == first  # a caller's copy is its own


def test_changed_or_replaced_input_is_read_again(tmp_path, reads):
    path = tmp_path / "notes.yaml"
    path.write_text("a: 1\n")
    with inputs_read_once():
        before = input_record(path)
        path.write_text("a: 2\n")  # same size, new content
        os.utime(path, ns=(1, 1))  # even with an old modification time: the change time moved
        after = input_record(path)
        map_path = tmp_path / "map.h5"
        _map(map_path, 0.0)
        flat = input_record(map_path)
        _map(map_path, 0.5)  # replaced (a new file renamed over it)
        raised = input_record(map_path)
    assert before["sha256"] != after["sha256"]
    assert flat["terrain"] != raised["terrain"]
    assert reads == [str(path), str(path), str(map_path), str(map_path)]


def test_outside_the_block_every_call_reads(tmp_path, reads):
    path = tmp_path / "notes.yaml"
    path.write_text("a: 1\n")
    input_record(path)
    input_record(path)
    with inputs_read_once():
        input_record(path)
    input_record(path)
    assert len(reads) == 4
