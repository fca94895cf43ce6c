"""NavGrids for the nav tests, built from an occupancy array through `legplan.terrain` (a module
beside tests/conftest.py, importable from every test folder: a `conftest` import is ambiguous once
several test folders have one)."""

import numpy as np

from legplan.nav import NavGrid
from legplan.terrain import costmap_from_distance, obstacle_distance


def grid_from_occupancy(occupancy, resolution, l1=0.1, l2=0.4, c_max=100.0, lambda_c=5.0,
                        origin=None):
    """NavGrid of `occupancy` (True = obstacle) at `resolution` with the costmap of eqs. (15)-(16);
    cell [0, 0]'s centre at `origin` (default: the lower-left corner at 0, 0)."""
    occupancy = np.asarray(occupancy, bool)
    distance = obstacle_distance(occupancy, resolution)
    costmap = costmap_from_distance(distance, l1, l2, c_max, lambda_c)
    origin = (0.5 * resolution, 0.5 * resolution) if origin is None else origin
    return NavGrid(costmap, distance, l1, origin, resolution)
