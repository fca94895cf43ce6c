"""Fixtures shared across test packages: the scarab2 robot and small terrains at 1 cm."""

import numpy as np
import pytest

from legplan.robots import load_robot
from legplan.terrain import Grid2D, terrain_from_heightmap

_GRID = dict(origin=(-0.6, -0.5), resolution=0.01, shape=(101, 121))


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
