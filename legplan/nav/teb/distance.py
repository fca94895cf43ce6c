"""Obstacle distance l(s) of the map's `/nav/distance` layer with its gradient, for TEB repulsion.

Bilinear interpolation between cell centres (the layer holds the distance from each cell centre to
the nearest obstacle cell centre); the gradient is the exact derivative of that interpolant, so it
is continuous inside a cell and jumps across cell edges. Points outside the grid are clamped onto
its border (value of the border, zero gradient across it).
"""

from __future__ import annotations

import numpy as np

from legplan.terrain.grid import Grid2D


class DistanceField:
    """`value_and_gradient(xy (k, 2)) -> (l (k,), ∇l (k, 2))` over a `Grid2D` distance layer (m)."""

    def __init__(self, distance: np.ndarray, grid: Grid2D):
        self.distance = np.asarray(distance, float)
        if self.distance.shape != tuple(grid.shape) or min(grid.shape) < 2:
            raise ValueError(f"distance layer {self.distance.shape} does not match grid {grid.shape} (need ≥ 2×2)")
        self.grid = grid

    @classmethod
    def from_terrain(cls, terrain) -> DistanceField:
        return cls(terrain.distance, terrain.grid)

    def value_and_gradient(self, xy) -> tuple[np.ndarray, np.ndarray]:
        u, v = self.grid.continuous_index(xy)
        ny, nx = self.distance.shape
        ix, tx, inside_x = _corner(u, nx)
        iy, ty, inside_y = _corner(v, ny)
        d = self.distance
        d00, d01 = d[iy, ix], d[iy, ix + 1]
        d10, d11 = d[iy + 1, ix], d[iy + 1, ix + 1]
        bottom = d00 + (d01 - d00) * tx
        top = d10 + (d11 - d10) * tx
        value = bottom + (top - bottom) * ty
        scale = 1.0 / self.grid.resolution
        gx = ((d01 - d00) * (1 - ty) + (d11 - d10) * ty) * scale * inside_x
        gy = (top - bottom) * scale * inside_y
        return value, np.stack([gx, gy], axis=1)

    def values(self, xy) -> np.ndarray:
        return self.value_and_gradient(xy)[0]


def _corner(u: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower corner index in [0, n − 2], fraction in [0, 1], and 1.0 where u lies inside [0, n − 1]."""
    clamped = np.clip(u, 0.0, n - 1.0)
    lower = np.minimum(np.floor(clamped).astype(np.int64), n - 2)
    inside = ((u >= 0.0) & (u <= n - 1.0)).astype(float)
    return lower, clamped - lower, inside
