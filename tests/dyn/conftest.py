"""Fixtures of the centroidal optimizer tests: the ANYmal-like model and small terrains as TerrainModel."""

import numpy as np
import pytest

from legplan.dyn.terrain import TerrainModel
from legplan.robots import load_robot
from legplan.terrain import Grid2D, terrain_from_heightmap


@pytest.fixture(scope="session")
def anymal():
    return load_robot("anymal").centroidal


def _terrain(height_fn, name):
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))
    x, y = grid.centres()
    return TerrainModel(terrain_from_heightmap(height_fn(x, y), grid, name=name))


@pytest.fixture(scope="session")
def flat():
    return _terrain(lambda x, y: np.zeros_like(x), "flat")


@pytest.fixture(scope="session")
def step():
    """A 10 cm step at x ≥ 0.5 with a 4 cm ramp (TOWR's Block shape)."""
    return _terrain(lambda x, y: 0.1 * np.clip((x - 0.46) / 0.04, 0.0, 1.0), "step")
