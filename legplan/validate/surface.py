"""The terrain surface as an FCL triangle mesh, for checks independent of the planners' SDF.

The heightmap h[iy, ix] (cell centres at origin + resolution * (ix, iy)) is triangulated with one
vertex per cell centre and two triangles per grid square split along the (ix, iy)-(ix+1, iy+1)
diagonal. `signed_distance(points)` is the Euclidean distance of each point to that mesh
(`fcl.distance` against a zero-radius sphere), negative when the point lies below the surface.

Speed: an FCL query costs ~0.1 ms, so exact FCL distances are computed only where needed. Around a
point whose window of half-width `window` is flat (min == max height), the nearest surface point of a
point within `window` of the plane is straight below it, so the vertical gap is the exact distance.
`distance_bounds` gives cheap lower/upper bounds used to find the closest of many spheres with few
FCL calls (`Validator`).
"""

from __future__ import annotations

import math

import fcl
import numpy as np
from scipy import ndimage

_POINT_RADIUS = 1e-9


class SurfaceMesh:
    """Triangle mesh of a heightmap with exact signed point distances (FCL) and cheap bounds."""

    def __init__(self, height, origin, resolution: float, *, window: float = 0.1):
        self.height = np.asarray(height, dtype=float)
        self.origin = np.asarray(origin, dtype=float)[:2]
        self.resolution = float(resolution)
        ny, nx = self.height.shape
        if ny < 2 or nx < 2:
            raise ValueError(f"heightmap must be at least 2x2 cells, got {self.height.shape}")
        iy, ix = np.mgrid[0:ny, 0:nx]
        vertices = np.stack([self.origin[0] + ix.ravel() * self.resolution,
                             self.origin[1] + iy.ravel() * self.resolution,
                             self.height.ravel()], axis=1)
        corner = (iy[:-1, :-1] * nx + ix[:-1, :-1]).ravel()
        triangles = np.concatenate([np.stack([corner, corner + 1, corner + nx + 1], axis=1),
                                    np.stack([corner, corner + nx + 1, corner + nx], axis=1)])
        model = fcl.BVHModel()
        model.beginModel(len(vertices), len(triangles))
        model.addSubModel(vertices, triangles.astype(np.int64))
        model.endModel()
        self._mesh = fcl.CollisionObject(model, fcl.Transform())
        self._probe = fcl.CollisionObject(fcl.Sphere(_POINT_RADIUS), fcl.Transform())
        self._request = fcl.DistanceRequest()
        # window (in cells) covering every triangle that has a point within `window` horizontally
        half = int(math.ceil(window / self.resolution)) + 2
        self.window = (half - 2) * self.resolution
        size = 2 * half + 1
        self._hmax = ndimage.maximum_filter(self.height, size=size, mode="nearest")
        self._hmin = ndimage.minimum_filter(self.height, size=size, mode="nearest")

    def _cells(self, xy: np.ndarray):
        """Grid coordinates: lower-left cell index (clipped) and the fractional offsets in it."""
        g = (xy - self.origin) / self.resolution
        ny, nx = self.height.shape
        ix = np.clip(np.floor(g[:, 0]).astype(int), 0, nx - 2)
        iy = np.clip(np.floor(g[:, 1]).astype(int), 0, ny - 2)
        u = np.clip(g[:, 0] - ix, 0.0, 1.0)
        v = np.clip(g[:, 1] - iy, 0.0, 1.0)
        return ix, iy, u, v

    def surface_height(self, xy) -> np.ndarray:
        """Height of the mesh straight above/below xy (n, 2) (clamped to the map border)."""
        xy = np.asarray(xy, dtype=float)[:, :2]
        ix, iy, u, v = self._cells(xy)
        h = self.height
        h00, h10, h01, h11 = h[iy, ix], h[iy, ix + 1], h[iy + 1, ix], h[iy + 1, ix + 1]
        lower = u >= v  # triangle (0,0)-(1,0)-(1,1); else (0,0)-(1,1)-(0,1)
        return np.where(lower, h00 + u * (h10 - h00) + v * (h11 - h10),
                        h00 + v * (h01 - h00) + u * (h11 - h01))

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

        Above the surface: d <= vertical gap, and d >= min(window, z - max height in the window).
        Below it: vertical gap <= d <= 0. Where the window is flat and the gap within it, lb = ub.
        """
        p = np.asarray(points, dtype=float)
        gap = self.vertical_gap(p)
        iy, ix = self._nearest_cell(p[:, :2])
        hmax, hmin = self._hmax[iy, ix], self._hmin[iy, ix]
        above = gap >= 0.0
        lb = np.where(above, np.minimum(self.window, p[:, 2] - hmax), gap)
        ub = np.where(above, gap, 0.0)
        exact = (hmax == hmin) & (np.abs(gap) <= self.window) & self.inside_map(p[:, :2])
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
