"""The simulated world: true and known occupancy on one grid, the known nav layers, sensing of
hidden obstacles, and the collision judge.

Collision model (one for planning and judging): the robot is the disc of `collision_radius` (the
robot's circumscribed radius, a disc that contains its footprint) around its position, and
obstacles are occupied cells taken at their centres — the distance field's model. The planners
plan on the known map with that radius as their lethal radius l1 (`nav_grid`) and the TEB keeps at
least that distance (`run_navigation`); a pose is in collision when an occupied cell centre of the *true*
map lies closer than the radius, or the disc leaves the map.
"""

from __future__ import annotations

import numpy as np

from legplan.nav.collision import NavGrid
from legplan.nav.teb.distance import DistanceField
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import CostmapParams, costmap_from_distance, obstacle_distance


class World:
    """True occupancy (known | hidden), the known part and its nav layers (`distance`, `nav_grid`)."""

    def __init__(self, grid: Grid2D, occupancy: np.ndarray, hidden: np.ndarray, costmap: CostmapParams,
                 collision_radius: float):
        self.grid = grid
        self.true_occupancy = occupancy | hidden
        self.known = occupancy.copy()
        self.hidden = hidden & ~occupancy
        self.costmap_params = costmap
        self.collision_radius = float(collision_radius)
        X, Y = grid.centres()
        self._centres = np.stack([X, Y], axis=-1)
        reach = int(np.ceil(self.collision_radius / grid.resolution)) + 1
        self._window = np.arange(-reach, reach + 1)
        self._rebuild()

    def _rebuild(self) -> None:
        c = self.costmap_params
        distance = obstacle_distance(self.known, self.grid.resolution)
        self.distance = DistanceField(distance, self.grid)
        self.nav_grid = NavGrid(costmap_from_distance(distance, c.l1, c.l2, c.c_max, c.lambda_c), distance,
                                max(c.l1, self.collision_radius), self.grid.origin, self.grid.resolution)

    def sense(self, xy: np.ndarray, radius: float) -> bool:
        """Reveal hidden obstacle cells within `radius` of `xy`; True when the known map changed."""
        if not self.hidden.any():
            return False
        near = self.hidden & (np.sum((self._centres - xy) ** 2, axis=-1) <= radius * radius)
        if not near.any():
            return False
        self.known |= near
        self.hidden &= ~near
        self._rebuild()
        return True

    def in_collision(self, pose: np.ndarray) -> bool:
        """Whether the collision disc at `pose` (x, y, θ) holds an occupied cell centre of the true
        map or leaves the map (module docstring)."""
        xmin, xmax, ymin, ymax = self.grid.extent
        x, y, r = float(pose[0]), float(pose[1]), self.collision_radius
        if x - r < xmin or x + r > xmax or y - r < ymin or y + r > ymax:
            return True
        (iy,), (ix,), _ = self.grid.cell_of([[x, y]])
        ny, nx = self.grid.shape
        rows = np.clip(iy + self._window, 0, ny - 1)
        cols = np.clip(ix + self._window, 0, nx - 1)
        near = self.true_occupancy[np.ix_(rows, cols)]
        if not near.any():
            return False
        dy = self.grid.ys[rows][:, None] - y
        dx = self.grid.xs[cols][None, :] - x
        return bool(np.any(near & (dx * dx + dy * dy < r * r)))
