"""3D signed distance field of a heightmap, with vectorized trilinear value + gradient lookup.

Construction (per height layer, in the manner of ANYbotics grid_map's SignedDistanceField, made exact
in the vertical direction). The solid is the set of columns below the heightmap: cell c is a square
column of side r reaching up to H_c. Layers sit at z_k = z0 + k r (r = grid resolution, z0 a
multiple of r). For each layer k:

- occupied_k = H > z_k (the voxel centre is below the surface);
- 2D Euclidean distance transform (scipy.ndimage.distance_transform_edt, with indices) of the free
  cells: the nearest occupied cell c at that layer, its edge distance h_k = max(|centre - c| - r/2, 0)
  and its top H_c (+inf distance when the layer has no occupied cell);
- the same for the occupied cells: nearest free cell c at that layer, f_k and its top H_c.

The layers are then combined vertically (a lower envelope over layers, the third pass of a
separable 3D distance transform), using the real top of each layer's nearest column:

  free voxel (z_j >= H):     d = +min_{k<=j} sqrt(h_k^2 + max(z_j - H_c(k), 0)^2)
  occupied voxel (z_j < H):  d = -min_{k>=j} sqrt(f_k^2 + max(H_c(k) - z_j, 0)^2)

A cell's own column is its own nearest neighbour (h = 0), which gives the exact vertical distance
z_j - H. Unlike grid_map's min(horizontal, vertical) of a single layer, a point above a beam's top
next to its edge sees the edge at the diagonal distance instead of the far floor below. Against the
column solid the error is below one cell: half a cell horizontally from the edge offset on
diagonals, and at most one layer vertically when a lower column is horizontally nearer.

Lookup is trilinear between voxel centres. Outside the grid the field is extended, never raising:
in x and y the point is clamped to the grid (the terrain continues as its border cells; gradient 0
in a clamped direction); in z the field continues linearly with slope 1 beyond the bottom and top
layers (value at the clamped point + (z - z_clamped); gradient_z = 1), i.e. "further above the
top layer is further from the terrain, deeper below the bottom is deeper inside".
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Progress = Callable[..., None]


class SignedDistanceField:
    """Voxel samples `values` (nz, ny, nx) m at `origin + resolution * (ix, iy, iz)`."""

    def __init__(self, values: np.ndarray, origin, resolution: float):
        values = np.asarray(values, dtype=np.float32)
        if values.ndim != 3 or min(values.shape) < 2:
            raise ValueError(f"SDF needs at least 2 samples per axis, got shape {values.shape}")
        self.data = values
        self.origin = np.asarray(origin, dtype=float).reshape(3)
        self.resolution = float(resolution)

    @property
    def shape(self) -> tuple[int, int, int]:
        return self.data.shape

    @property
    def z_levels(self) -> np.ndarray:
        return self.origin[2] + self.resolution * np.arange(self.data.shape[0])

    def values(self, points, bound=None) -> np.ndarray:
        """Signed distance (m) at points (n, 3): positive in free space, negative inside terrain (`bound`:
        accepted for the interface of `ColumnDistance.values`; the lookup is exact everywhere)."""
        return self.value_and_gradient(points)[0]

    def value_and_gradient(self, points, bound=None) -> tuple[np.ndarray, np.ndarray]:
        """(values (n,), gradients (n, 3)) of the trilinear interpolant at points (n, 3) (`bound`: as in `values`).

        The gradient is the exact derivative of the interpolant (piecewise, one-sided on cell faces).
        """
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        nz, ny, nx = self.data.shape
        scaled = (points - self.origin) / self.resolution
        ix, tx, in_x = _axis(scaled[:, 0], nx)
        iy, ty, in_y = _axis(scaled[:, 1], ny)
        iz, tz, in_z = _axis(scaled[:, 2], nz)
        flat = self.data.reshape(-1)
        base = (iz * ny + iy) * nx + ix
        sx, sy, sz = 1, nx, nx * ny

        def corner(dz, dy, dx):
            return flat[base + dz * sz + dy * sy + dx * sx].astype(float)

        c000, c001, c010, c011 = corner(0, 0, 0), corner(0, 0, 1), corner(0, 1, 0), corner(0, 1, 1)
        c100, c101, c110, c111 = corner(1, 0, 0), corner(1, 0, 1), corner(1, 1, 0), corner(1, 1, 1)
        d00, d01, d10, d11 = c001 - c000, c011 - c010, c101 - c100, c111 - c110
        l00, l01, l10, l11 = c000 + tx * d00, c010 + tx * d01, c100 + tx * d10, c110 + tx * d11
        p0, p1 = l00 + ty * (l01 - l00), l10 + ty * (l11 - l10)
        value = p0 + tz * (p1 - p0)
        grad = np.empty_like(points)
        grad[:, 0] = ((1 - tz) * ((1 - ty) * d00 + ty * d01) + tz * ((1 - ty) * d10 + ty * d11))
        grad[:, 1] = (1 - tz) * (l01 - l00) + tz * (l11 - l10)
        grad[:, 2] = p1 - p0
        grad /= self.resolution
        grad[~in_x, 0] = 0.0
        grad[~in_y, 1] = 0.0
        grad[~in_z, 2] = 1.0
        z_excess = points[:, 2] - (self.origin[2] + self.resolution * (iz + tz))
        return value + z_excess, grad


def _axis(u: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Lower sample index in [0, n-2], fraction in [0, 1] and whether `u` lies inside [0, n-1]."""
    inside = (u >= 0.0) & (u <= n - 1.0)
    clamped = np.clip(u, 0.0, n - 1.0)
    lower = np.minimum(np.floor(clamped).astype(np.int64), n - 2)
    return lower, clamped - lower, inside


def sdf_layers(z_min: float, z_max: float, resolution: float) -> np.ndarray:
    """Layer heights z0 + k r covering [z_min, z_max], z0 a multiple of r (at least two layers)."""
    start = np.floor(z_min / resolution + 1e-9) * resolution
    count = max(int(np.ceil((z_max - start) / resolution - 1e-9)) + 1, 2)
    return start + resolution * np.arange(count)


def heightmap_sdf(height: np.ndarray, origin_xy, resolution: float, z_min: float, z_max: float,
                  progress: Progress | None = None) -> SignedDistanceField:
    """Signed distance field of the column solid below `height` (ny, nx); see the module docstring."""
    height = np.asarray(height, dtype=float)
    r = float(resolution)
    zs = sdf_layers(z_min, z_max, r)
    nz, cells = zs.size, height.size
    free_h2 = np.empty((nz, cells), dtype=np.float32)
    free_top = np.empty((nz, cells), dtype=np.float32)
    occupied_h2 = np.empty((nz, cells), dtype=np.float32)
    occupied_top = np.empty((nz, cells), dtype=np.float32)
    for k, z in enumerate(zs):
        occupied = height > z
        free_h2[k], free_top[k] = _nearest_column(~occupied, height, r)
        occupied_h2[k], occupied_top[k] = _nearest_column(occupied, height, r)
        if progress is not None:
            progress(k + 1, 2 * nz, "layer distance transforms")
    flat_height = height.reshape(-1)
    values = np.empty((nz, cells), dtype=np.float32)
    for j, z in enumerate(zs):
        z = np.float32(z)
        below = free_h2[:j + 1] + np.maximum(z - free_top[:j + 1], 0) ** 2
        above = occupied_h2[j:] + np.maximum(occupied_top[j:] - z, 0) ** 2
        values[j] = np.where(z >= flat_height, np.sqrt(below.min(axis=0)),
                             -np.sqrt(above.min(axis=0)))
        if progress is not None:
            progress(nz + j + 1, 2 * nz, "vertical combination")
    origin = (float(origin_xy[0]), float(origin_xy[1]), float(zs[0]))
    return SignedDistanceField(values.reshape(nz, *height.shape), origin, r)


def _nearest_column(mask: np.ndarray, height: np.ndarray, r: float):
    """Squared edge distance from each cell to the nearest cell outside `mask`, and that cell's top.

    Cells outside `mask` are their own nearest (distance 0). Without any such cell the distance is
    +inf everywhere (and the top irrelevant).
    """
    from scipy.ndimage import distance_transform_edt  # map building only

    if mask.all():
        return np.inf, 0.0
    centre, (iy, ix) = distance_transform_edt(mask, return_indices=True)
    edge = np.maximum(centre * r - 0.5 * r, 0.0)
    return (edge ** 2).reshape(-1), height[iy, ix].reshape(-1)
