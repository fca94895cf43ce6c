"""Fixtures shared across test packages: the scarab2 robot, small terrains at 1 cm, and map / steps
files of the scenes many stages' tests use (box scene, flat, block and wall maps).

Helper modules beside this file (`scenes`, `wallmap`, `fake_artefacts`, `pictures`, `robot_helpers`)
are importable from every test directory: pytest puts this conftest's directory on `sys.path`."""

import os

import numpy as np
import pytest
from scenes import BoxFiles
from wallmap import build_wall_map

from legplan.robots import load_robot
from legplan.terrain import Grid2D, save_map, terrain_from_heightmap

_GRID = dict(origin=(-0.6, -0.5), resolution=0.01, shape=(101, 121))


@pytest.fixture(scope="session", autouse=True)
def filter_store(tmp_path_factory):
    """The store of `legplan.cache` in a folder of this session (commands run by tests included),
    not the user's cache."""
    saved = os.environ.get("LEGPLAN_CACHE_DIR")
    os.environ["LEGPLAN_CACHE_DIR"] = str(tmp_path_factory.mktemp("filter-store"))
    yield
    if saved is None:
        os.environ.pop("LEGPLAN_CACHE_DIR", None)
    else:
        os.environ["LEGPLAN_CACHE_DIR"] = saved


@pytest.fixture(scope="session")
def scarab():
    return load_robot("scarab2")


@pytest.fixture(scope="session")
def step_terrain():
    """1.2 x 1.0 m at 1 cm: ground z = 0 and a 4 cm high block for x > 0.3."""
    grid = Grid2D(**_GRID)
    x, _ = grid.centres()
    return terrain_from_heightmap(np.where(x > 0.3, 0.04, 0.0), grid, name="step")


@pytest.fixture(scope="session")
def flat_terrain():
    grid = Grid2D(**_GRID)
    return terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")


@pytest.fixture(scope="session")
def box(tmp_path_factory):
    """The box scene (`scenes.box_scene`: jueying_mini, a 1.5 cm box ahead of its left front foot)
    with its map.h5 and steps files (`scenes.BoxFiles`), built once per session."""
    return BoxFiles(tmp_path_factory.mktemp("box"))


@pytest.fixture(scope="session")
def flat_map(tmp_path_factory):
    """Flat 1.2 x 0.8 m ground at 1 cm, as a TerrainMap and a map.h5 path."""
    grid = Grid2D(origin=(-0.6, -0.4), resolution=0.01, shape=(81, 121))
    terrain = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat_small")
    path = tmp_path_factory.mktemp("maps") / "flat.h5"
    save_map(terrain, path)
    return terrain, path


@pytest.fixture(scope="session")
def block_map(tmp_path_factory):
    """map.h5 of 8 x 5 m at 10 cm with a 0.5 m high 1 x 2 m block (x 3.5-4.5 m, y 1-3 m): navigation
    queries from one side to the other go round it."""
    height = np.zeros((50, 80))
    height[10:30, 35:45] = 0.5
    path = tmp_path_factory.mktemp("maps") / "block.h5"
    save_map(terrain_from_heightmap(height, Grid2D((0.05, 0.05), 0.1, height.shape), name="block"), path)
    return path


@pytest.fixture(scope="session")
def wall_map(tmp_path_factory):
    """map.h5 of 6 m x 4 m at 5 cm whose wall blocks the straight line (1, 1) -> (5, 1) (`wallmap.py`)."""
    return build_wall_map(tmp_path_factory.mktemp("wallmap"))
