"""Fixtures of fake artefacts (writers in fake_artefacts.py)."""

import pytest
from fake_artefacts import write_map, write_motion, write_robot_motion

from legplan.terrain.terrain_map import save_map


@pytest.fixture
def artefacts(tmp_path):
    map_path = write_map(tmp_path / "map.h5")
    return map_path, write_motion(tmp_path / "motion.h5", inputs=[map_path])


@pytest.fixture
def robot_motion(tmp_path, flat_terrain, monkeypatch):
    """(map, motion of scarab2 on it), written from `tmp_path/work` with relative paths, as a
    pipeline records them; the current directory is `tmp_path/work`."""
    work = tmp_path / "work"
    (work / "out").mkdir(parents=True)
    monkeypatch.chdir(work)
    map_path = "out/map.h5"
    save_map(flat_terrain, map_path)
    return work / map_path, work / write_robot_motion("out/motion.h5", map_path)
