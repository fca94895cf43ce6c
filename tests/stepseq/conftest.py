import numpy as np
import pytest

from legplan.terrain import Grid2D, save_map, terrain_from_heightmap
from legplan.validate import Validator


@pytest.fixture(scope="session")
def flat_map(tmp_path_factory):
    """Flat 1.2 x 0.8 m ground at 1 cm, as a TerrainMap and a map.h5 path."""
    grid = Grid2D(origin=(-0.6, -0.4), resolution=0.01, shape=(81, 121))
    terrain = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat_small")
    path = tmp_path_factory.mktemp("maps") / "flat.h5"
    save_map(terrain, path)
    return terrain, path


@pytest.fixture(scope="session")
def validator(scarab, flat_map):
    return Validator(scarab, flat_map[0])
