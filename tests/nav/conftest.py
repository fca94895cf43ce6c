"""Shared fixtures of the nav search tests: small NavGrids built through `legplan.terrain`."""

import numpy as np
import pytest

from navgrids import grid_from_occupancy


@pytest.fixture
def pillars_grid():
    """10 m × 6 m at 5 cm with three round pillars and a wall stub."""
    resolution = 0.05
    ny, nx = 120, 200
    y, x = (np.mgrid[0:ny, 0:nx] + 0.5) * resolution
    occupancy = np.zeros((ny, nx), bool)
    for cx, cy, r in ((3.0, 3.0, 0.8), (6.0, 1.5, 0.6), (6.5, 4.5, 0.7)):
        occupancy |= (x - cx) ** 2 + (y - cy) ** 2 < r * r
    occupancy[:80, 85:88] |= True
    return grid_from_occupancy(occupancy, resolution, l1=0.2, l2=0.6)
