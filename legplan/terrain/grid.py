"""A regular 2D grid of square cells: the frame shared by the heightmap and every 2D layer.

Arrays are indexed `[iy, ix]`; `origin` is the world (x, y) of the centre of cell `[0, 0]`, so the
centre of cell `[iy, ix]` is `origin + resolution * (ix, iy)` and the grid covers
`[x0 - r/2, x0 + (nx - 1/2) r] x [y0 - r/2, y0 + (ny - 1/2) r]`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Grid2D:
    """Geometry of a cell grid: `origin` (x0, y0) of cell [0, 0]'s centre, `resolution` (m), `shape` (ny, nx)."""

    origin: tuple[float, float]
    resolution: float
    shape: tuple[int, int]

    @property
    def xs(self) -> np.ndarray:
        """World x of the cell centres of one row, shape (nx,)."""
        return self.origin[0] + self.resolution * np.arange(self.shape[1])

    @property
    def ys(self) -> np.ndarray:
        """World y of the cell centres of one column, shape (ny,)."""
        return self.origin[1] + self.resolution * np.arange(self.shape[0])

    def centres(self) -> tuple[np.ndarray, np.ndarray]:
        """World (X, Y) of every cell centre, each of shape (ny, nx)."""
        return np.meshgrid(self.xs, self.ys)

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """Outer cell edges (xmin, xmax, ymin, ymax), e.g. for `imshow(extent=...)`."""
        half = 0.5 * self.resolution
        return (self.origin[0] - half, self.xs[-1] + half, self.origin[1] - half, self.ys[-1] + half)

    def continuous_index(self, xy) -> tuple[np.ndarray, np.ndarray]:
        """Fractional (ix, iy) of world points `xy` (n, 2): cell centres sit at integers."""
        xy = np.asarray(xy)
        xy = xy.astype(np.result_type(xy.dtype, float)).reshape(-1, 2)  # complex points stay complex
        return ((xy[:, 0] - self.origin[0]) / self.resolution,
                (xy[:, 1] - self.origin[1]) / self.resolution)

    def cell_of(self, xy) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(iy, ix, inside) of the cell containing each point; indices clipped into the grid. A cell
        holds [centre − r/2, centre + r/2) per axis (floor(u + 1/2): the one rounding of every
        layer lookup, the nav search's padded gathers included)."""
        u, v = self.continuous_index(xy)
        ix, iy = np.floor(u + 0.5).astype(np.int64), np.floor(v + 0.5).astype(np.int64)
        inside = (ix >= 0) & (ix < self.shape[1]) & (iy >= 0) & (iy < self.shape[0])
        return np.clip(iy, 0, self.shape[0] - 1), np.clip(ix, 0, self.shape[1] - 1), inside

    def outside_problem(self, xy, names) -> str | None:
        """"NAME at (x, y) is outside the map (x .., y ..)" for the first of the points `xy` (n, 2)
        that lies in no cell (`names[i]` names point i), or None when all lie on the grid."""
        xy = np.asarray(xy, dtype=float).reshape(-1, 2)
        inside = self.cell_of(xy)[2]
        if inside.all():
            return None
        i = int(np.argmin(inside))
        x0, x1, y0, y1 = self.extent
        return (f"{names[i]} at ({xy[i, 0]:.3f}, {xy[i, 1]:.3f}) is outside the map "
                f"(x {x0:.3f}..{x1:.3f}, y {y0:.3f}..{y1:.3f})")

    def cell_center(self, iy, ix) -> np.ndarray:
        """World coordinates (..., 2) of the centres of cells [iy, ix] (arrays or ints)."""
        return np.stack([self.origin[0] + np.asarray(ix) * self.resolution,
                         self.origin[1] + np.asarray(iy) * self.resolution], axis=-1)

    def nearest(self, array: np.ndarray, xy) -> np.ndarray:
        """Value of the cell containing each point (border cells repeat outside the grid)."""
        iy, ix, _ = self.cell_of(xy)
        return np.asarray(array)[iy, ix]

    def bilinear(self, array: np.ndarray, xy, gradient: bool = False):
        """Bilinear interpolation of a cell-centred `array` (ny, nx) at points `xy` (n, 2), and with
        `gradient` also its exact gradient (n, 2) (per m; continuous inside a cell, jumping across
        cell centre lines).

        Outside the grid the border values are repeated (the point is clamped into the grid), with
        zero gradient across the border.
        """
        flat = np.asarray(array, dtype=float).ravel()
        ny, nx = self.shape
        u, v = self.continuous_index(xy)
        ix, tx, inside_x = _cell_and_fraction(u, nx)
        iy, ty, inside_y = _cell_and_fraction(v, ny)
        step_x, step_y = min(nx - 1, 1), nx * min(ny - 1, 1)
        k = iy * nx + ix
        a00, a01, a10, a11 = flat[k], flat[k + step_x], flat[k + step_y], flat[k + step_y + step_x]
        bottom = a00 * (1 - tx) + a01 * tx
        top = a10 * (1 - tx) + a11 * tx
        value = bottom * (1 - ty) + top * ty
        if not gradient:
            return value
        scale = 1.0 / self.resolution
        gx = ((a01 - a00) * (1 - ty) + (a11 - a10) * ty) * scale * inside_x
        gy = (top - bottom) * scale * inside_y
        return value, np.stack([gx, gy], axis=1)


def _cell_and_fraction(u: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower corner index in [0, n-2], fraction in [0, 1] of clamped coordinates `u`, and 1.0 where
    `u` lies inside [0, n - 1] (0.0 where it was clamped). Complex `u` (complex-step differentiation):
    the cell from the real part; inside, the fraction keeps the imaginary part, so the interpolation
    is a polynomial in u and its complex step exact."""
    real = np.real(u)
    clamped = np.clip(real, 0.0, n - 1.0)
    lower = np.clip(np.floor(clamped).astype(np.int64), 0, max(n - 2, 0))
    inside = real == clamped
    return lower, np.where(inside, u - lower, clamped - lower), inside.astype(float)
