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

    def value_and_gradient(self, xy, gradient: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """l at points xy (k, 2) and (if `gradient`) ∇l (k, 2) (`Grid2D.bilinear`)."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        if not gradient:
            return self.grid.bilinear(self.distance, xy), None
        return self.grid.bilinear(self.distance, xy, gradient=True)

    def values(self, xy) -> np.ndarray:
        return self.value_and_gradient(xy, gradient=False)[0]
