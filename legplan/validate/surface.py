"""The terrain surface as an FCL triangle mesh, for checks independent of the planners' SDF.

The terrain is the column solid of the heightmap (as `legplan.terrain` defines it): cell [iy, ix]
is a square column of side r centred at origin + r (ix, iy) reaching up to h[iy, ix]. Its surface
is triangulated exactly: two triangles for every column top and two for every vertical wall
between neighbouring columns of different height. `signed_distance(points)` is the Euclidean
distance of each point to that surface (`fcl.distance` against a zero-radius sphere), negative
when the point lies inside the solid (below the top of its own column).

Speed: an FCL query costs ~0.1 ms, so exact FCL distances are computed only where needed. When
the vertical gap of a point to its column top is at most the horizontal distance to the nearest
column face (the cell's "flat radius"), the nearest surface point is straight below (above) it, so
the gap is the exact distance. `distance_bounds` gives cheap lower/upper bounds used to find the closest of many spheres
with few FCL calls (`Validator`).
"""

from __future__ import annotations

import math

import fcl
import numpy as np

from legplan.cache import filtered

_POINT_RADIUS = 1e-9


class SurfaceMesh:
    """Triangle mesh of a heightmap with exact signed point distances (FCL) and cheap bounds."""

    def __init__(self, height, origin, resolution: float, *, window: float = 0.1):
        self.height = np.asarray(height, dtype=float)
        self.origin = np.asarray(origin, dtype=float)[:2]
        self.resolution = float(resolution)
        if self.height.ndim != 2 or min(self.height.shape) < 1:
            raise ValueError(f"heightmap must be a 2D array, got shape {self.height.shape}")
        vertices, triangles = column_surface(self.height, self.origin, self.resolution)
        model = fcl.BVHModel()
        model.beginModel(len(vertices), len(triangles))
        model.addSubModel(vertices, triangles)
        model.endModel()
        self._mesh = fcl.CollisionObject(model, fcl.Transform())
        self._probe = fcl.CollisionObject(fcl.Sphere(_POINT_RADIUS), fcl.Transform())
        self._request = fcl.DistanceRequest()
        # window (in cells) covering every column that has a point within `window` horizontally
        half = int(math.ceil(window / self.resolution)) + 1
        self.window = (half - 1) * self.resolution
        size = 2 * half + 1
        self._hmax = filtered("maximum_filter", self.height, size=size, mode="nearest")
        # flat radius: horizontal distance from anywhere in a cell to the nearest column face
        # (a face lies half a cell beyond a cell whose height differs from a 4-neighbour's)
        h = self.height
        edge = np.zeros(h.shape, bool)
        edge[:, :-1] |= h[:, :-1] != h[:, 1:]
        edge[:, 1:] |= h[:, :-1] != h[:, 1:]
        edge[:-1, :] |= h[:-1, :] != h[1:, :]
        edge[1:, :] |= h[:-1, :] != h[1:, :]
        if edge.any():
            centre = filtered("distance_transform_edt", ~edge) * self.resolution
            self._flat = np.maximum(centre - 0.5 * self.resolution - 0.5 * math.sqrt(2) * self.resolution, 0.0)
        else:
            self._flat = np.full(h.shape, np.inf)

    def surface_height(self, xy) -> np.ndarray:
        """Top of the column containing each xy (n, 2) (border columns continue outside the map)."""
        iy, ix = self._nearest_cell(np.asarray(xy, dtype=float)[:, :2])
        return self.height[iy, ix]

    def _nearest_cell(self, xy: np.ndarray):
        g = np.rint((xy - self.origin) / self.resolution).astype(int)
        ny, nx = self.height.shape
        return np.clip(g[:, 1], 0, ny - 1), np.clip(g[:, 0], 0, nx - 1)

    def vertical_gap(self, points) -> np.ndarray:
        """z minus the surface height below each point (n, 3)."""
        p = np.asarray(points, dtype=float)
        return p[:, 2] - self.surface_height(p[:, :2])

    def distance_bounds(self, points):
        """Bounds lb <= d <= ub of the signed surface distance d of points (n, 3), and `exact` mask.

        Above the surface: d <= vertical gap, and d >= min(window, z - max height in the window) and
        d >= min(gap, flat radius). Below it: vertical gap <= d <= 0. Where the gap is within the
        flat radius (distance to the nearest column face), lb = ub = gap.
        """
        p = np.asarray(points, dtype=float)
        gap = self.vertical_gap(p)
        iy, ix = self._nearest_cell(p[:, :2])
        hmax, flat = self._hmax[iy, ix], self._flat[iy, ix]
        above = gap >= 0.0
        lb = np.where(above, np.maximum(np.minimum(self.window, p[:, 2] - hmax), np.minimum(gap, flat)), gap)
        ub = np.where(above, gap, 0.0)
        exact = (np.abs(gap) <= flat) & self.inside_map(p[:, :2])
        lb = np.where(exact, gap, lb)
        ub = np.where(exact, gap, ub)
        return lb, ub, exact

    def inside_map(self, xy) -> np.ndarray:
        """True where xy lies within the window-shrunk map area (bounds are valid there)."""
        g = (np.asarray(xy, dtype=float)[:, :2] - self.origin) / self.resolution
        ny, nx = self.height.shape
        margin = self.window / self.resolution + 1
        return ((g[:, 0] >= margin) & (g[:, 0] <= nx - 1 - margin)
                & (g[:, 1] >= margin) & (g[:, 1] <= ny - 1 - margin))

    def fcl_distance(self, points) -> np.ndarray:
        """Exact signed distance of points (n, 3) to the mesh by FCL (negative below the surface)."""
        p = np.asarray(points, dtype=float)
        out = np.empty(len(p))
        for i, point in enumerate(p):
            self._probe.setTranslation(point)
            out[i] = fcl.distance(self._probe, self._mesh, self._request, fcl.DistanceResult())
        out = np.maximum(out, 0.0) + _POINT_RADIUS
        return np.where(self.vertical_gap(p) < 0.0, -out, out)

    def signed_distance(self, points) -> np.ndarray:
        """Signed distance of points (n, 3) to the surface: exact, FCL only where the bounds differ."""
        p = np.asarray(points, dtype=float)
        lb, _, exact = self.distance_bounds(p)
        out = lb.copy()
        todo = ~exact
        if np.any(todo):
            out[todo] = self.fcl_distance(p[todo])
        return out


def column_surface(height: np.ndarray, origin: np.ndarray, r: float):
    """Vertices (v, 3) and triangles (t, 3) of the tops and walls of the column solid.

    Column tops of one height that together form a rectangle (`top_rectangles`) are one pair of
    triangles on the rectangle's outer corners: the same surface with far fewer triangles and
    vertices (only those the triangles use are kept), so FCL builds its bounding-volume tree in a
    fraction of the time on maps with flat areas."""
    ny, nx = height.shape
    iy, ix = np.mgrid[0:ny, 0:nx]
    cx = origin[0] + r * ix
    cy = origin[1] + r * iy
    corners = []  # per cell: (-,-), (+,-), (+,+), (-,+)
    for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        corners.append(np.stack([cx + sx * r / 2, cy + sy * r / 2, height], axis=-1))
    vertices = np.stack(corners, axis=2).reshape(-1, 3)  # index 4 * cell + corner
    cell = (iy * nx + ix) * 4
    y0, x0, y1, x1 = top_rectangles(height).T
    low_left, low_right = cell[y0, x0], cell[y0, x1 - 1] + 1
    up_right, up_left = cell[y1 - 1, x1 - 1] + 2, cell[y1 - 1, x0] + 3
    tops = np.concatenate([np.stack([low_left, low_right, up_right], -1),
                           np.stack([low_left, up_right, up_left], -1)])
    walls = []
    # wall between (iy, ix) and (iy, ix + 1): their shared edge is corner 1-2 of the left cell and
    # corner 0-3 of the right cell
    left, right = cell[:, :-1], cell[:, 1:]
    differ = height[:, :-1] != height[:, 1:]
    a, b = left[differ], right[differ]
    walls += [np.stack([a + 1, a + 2, b + 3], -1), np.stack([a + 1, b + 3, b], -1)]
    # wall between (iy, ix) and (iy + 1, ix): corner 3-2 of the lower cell, 0-1 of the upper cell
    low, up = cell[:-1, :], cell[1:, :]
    differ = height[:-1, :] != height[1:, :]
    a, b = low[differ], up[differ]
    walls += [np.stack([a + 3, a + 2, b + 1], -1), np.stack([a + 3, b + 1, b], -1)]
    triangles = np.concatenate([tops] + walls).astype(np.int64)
    used, triangles = np.unique(triangles, return_inverse=True)
    return vertices[used], triangles.reshape(-1, 3)


def top_rectangles(height: np.ndarray) -> np.ndarray:
    """Rectangles (k, 4) of cells [y0:y1, x0:x1] of equal height that tile the grid: runs of equal
    height along each row, merged with the identical runs (same columns, same height) of the rows
    after it."""
    ny, nx = height.shape
    done, growing = [], {}  # growing: (x0, x1, height) -> first row
    for y, row in enumerate(height):
        starts = np.flatnonzero(np.r_[True, row[1:] != row[:-1]])
        ends = np.r_[starts[1:], nx]
        keys = [(a, b, float(row[a])) for a, b in zip(starts.tolist(), ends.tolist())]
        current = {key: growing.pop(key, y) for key in keys}
        done += [(first, a, y, b) for (a, b, _), first in growing.items()]
        growing = current
    done += [(first, a, ny, b) for (a, b, _), first in growing.items()]
    return np.asarray(done, dtype=np.int64).reshape(-1, 4)

