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
    """`value_and_gradient(xy (k, 2)) -> (l (k,), ∇l (k, 2))` over a `Grid2D` distance layer (m);
    the layer is read through its flattened view (one index per corner)."""

    def __init__(self, distance: np.ndarray, grid: Grid2D):
        self.distance = np.asarray(distance, float)
        if self.distance.shape != tuple(grid.shape) or min(grid.shape) < 2:
            raise ValueError(f"distance layer {self.distance.shape} does not match grid {grid.shape} (need ≥ 2×2)")
        self.grid = grid
        self._flat = self.distance.ravel()

    @classmethod
    def from_terrain(cls, terrain) -> DistanceField:
        return cls(terrain.distance, terrain.grid)

    def value_and_gradient(self, xy, gradient: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """l at points xy (k, 2) and (if `gradient`) ∇l (k, 2)."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        u, v = self.grid.continuous_index(xy)
        ny, nx = self.distance.shape
        ix, tx, inside_x = _corner(u, nx)
        iy, ty, inside_y = _corner(v, ny)
        k = iy * nx + ix
        d = self._flat
        d00, d01, d10, d11 = d[k], d[k + 1], d[k + nx], d[k + nx + 1]
        bottom = d00 + (d01 - d00) * tx
        top = d10 + (d11 - d10) * tx
        value = bottom + (top - bottom) * ty
        if not gradient:
            return value, None
        scale = 1.0 / self.grid.resolution
        gx = ((d01 - d00) * (1 - ty) + (d11 - d10) * ty) * scale * inside_x
        gy = (top - bottom) * scale * inside_y
        return value, np.stack([gx, gy], axis=1)

    def values(self, xy) -> np.ndarray:
        return self.value_and_gradient(xy, gradient=False)[0]


def _corner(u: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower corner index in [0, n − 2], fraction in [0, 1], and 1.0 where u lies inside [0, n − 1]."""
    clamped = np.clip(u, 0.0, n - 1.0)
    lower = np.minimum(clamped.astype(np.int64), n - 2)  # clamped ≥ 0: truncation is floor
    return lower, clamped - lower, (u == clamped).astype(float)
