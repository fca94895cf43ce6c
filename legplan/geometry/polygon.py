"""Convex support polygons: hull of the stance footholds, half-planes A p <= b, signed edge distance.

The stability constraint of the Bézier paper (Sec. II-B, item 2) keeps the centre of mass above the
support polygon, "the convex hull of the footholds": an affine inequality per edge. Here an edge i
with outward unit normal a_i and offset b_i contributes the margin m_i(p) = b_i - a_i . p (metres,
positive on the inner side), and the polygon's signed distance is d(p) = min_i m_i(p):

- inside, d(p) is exactly the Euclidean distance to the boundary (positive);
- outside, d(p) is minus the largest half-plane violation (negative, |d| <= Euclidean distance).

Its gradient w.r.t. p is -a_k of the active (minimising) edge k. Everything is batched over points.
A hull of two distinct points (collinear footholds) is a two-edge "polygon" whose margin is minus
the distance to the supporting line: never positive, as a segment supports nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

_AREA_EPS = 1e-12


def convex_hull_2d(points) -> np.ndarray:
    """Indices of the convex hull vertices of `points` (k, 2), counter-clockwise (monotone chain).

    Collinear and duplicate points are dropped; the first vertex is the lowest-x (then lowest-y) one.
    """
    pts = np.asarray(points, dtype=float)
    if pts.ndim != 2 or pts.shape[1] != 2:
        raise ValueError(f"points must have shape (k, 2), got {pts.shape}")
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    if len(order) <= 1:
        return order.copy()

    def cross(o, a, b):
        return ((pts[a, 0] - pts[o, 0]) * (pts[b, 1] - pts[o, 1])
                - (pts[a, 1] - pts[o, 1]) * (pts[b, 0] - pts[o, 0]))

    def half(indices):
        chain: list[int] = []
        for i in indices:
            while len(chain) >= 2 and cross(chain[-2], chain[-1], i) <= _AREA_EPS:
                chain.pop()
            chain.append(int(i))
        return chain

    lower = half(order)
    upper = half(order[::-1])
    hull = lower[:-1] + upper[:-1]
    if len(hull) == 2 and np.allclose(pts[hull[0]], pts[hull[1]]):
        hull = hull[:1]
    return np.asarray(hull, dtype=int)


@dataclass(frozen=True)
class ConvexPolygon:
    """A convex polygon as counter-clockwise `vertices` (h, 2) and half-planes `A p <= b`.

    `A` (h, 2) holds the outward unit normal of edge i (from vertex i to vertex i+1), `b` (h,) its
    offset, so `margins(p) = b - A p` is the distance of p to each edge line, positive inside.
    """

    vertices: np.ndarray
    A: np.ndarray
    b: np.ndarray

    @classmethod
    def from_vertices(cls, vertices) -> ConvexPolygon:
        """Polygon from counter-clockwise vertices (h >= 2 distinct points)."""
        v = np.asarray(vertices, dtype=float)
        if v.ndim != 2 or v.shape[1] != 2 or len(v) < 2:
            raise ValueError(f"a polygon needs at least 2 vertices (h, 2), got shape {v.shape}")
        edges = np.roll(v, -1, axis=0) - v
        lengths = np.linalg.norm(edges, axis=1)
        if np.any(lengths <= 0.0):
            raise ValueError("polygon vertices must be distinct")
        normals = np.stack([edges[:, 1], -edges[:, 0]], axis=1) / lengths[:, None]
        offsets = np.einsum("ij,ij->i", normals, v)
        return cls(vertices=v, A=normals, b=offsets)

    @property
    def area(self) -> float:
        """Enclosed area in m^2 (0 for a segment)."""
        x, y = self.vertices[:, 0], self.vertices[:, 1]
        return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

    def margins(self, points) -> np.ndarray:
        """Per-edge margins b - A p for points (n, 2) -> (n, h); gradient of column i is -A[i]."""
        p = np.asarray(points, dtype=float)[..., :2]
        return self.b - p @ self.A.T

    def signed_distance(self, points, *, return_gradient: bool = False):
        """Signed distance d(p) = min_i (b_i - a_i . p) of points (n, 2) (or (n, 3): z ignored).

        Returns (n,) values, positive inside; with `return_gradient` also the gradient (n, 2),
        -a_k of the active edge k.
        """
        m = self.margins(points)
        active = np.argmin(m, axis=-1)
        d = np.take_along_axis(m, active[..., None], axis=-1)[..., 0]
        if not return_gradient:
            return d
        return d, -self.A[active]

    def contains(self, points, margin: float = 0.0) -> np.ndarray:
        """True where the point is inside with at least `margin` (m) to every edge."""
        return self.signed_distance(points) >= margin


def support_polygon(footholds) -> ConvexPolygon:
    """The support polygon: convex hull of the stance footholds (k, 2) or (k, 3) (z ignored).

    Raises ValueError when fewer than two distinct footholds are given.
    """
    pts = np.asarray(footholds, dtype=float)
    if pts.ndim != 2 or pts.shape[1] not in (2, 3):
        raise ValueError(f"footholds must have shape (k, 2) or (k, 3), got {pts.shape}")
    hull = convex_hull_2d(pts[:, :2])
    if len(hull) < 2:
        raise ValueError("a support polygon needs at least two distinct footholds")
    return ConvexPolygon.from_vertices(pts[hull, :2])
