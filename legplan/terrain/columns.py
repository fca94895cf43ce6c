"""Exact signed distance (value + gradient) from points to the column solid of a heightmap.

The solid is the one every terrain layer uses: cell c (centre (x_c, y_c), side r) is the column
[x_c ± r/2] × [y_c ± r/2] × (−∞, H_c], and outside the grid the terrain continues as its border
cells (as in the SDF lookup and the validator's vertical gaps). For a point p outside
the solid the distance to column c is ‖(δx, δy, max(p_z − H_c, 0))‖ with δx = max(|p_x − x_c| − r/2, 0)
(δy alike); for a point inside, its depth is the distance to the nearest "air column"
[x_c ± r/2] × [y_c ± r/2] × [H_c, ∞), ‖(δx, δy, max(H_c − p_z, 0))‖. The signed distance is the
smallest of these over the cells, negative inside.

Which cells matter. The nearest point q of the solid (of the air) to p either lies straight below
(above) p on p's own column, or on a vertical line where columns of different heights meet; every
such line touches a cell with a 4-neighbour of a different height (an "edge" cell; proof: if q lies
on an edge or corner line of cell c with H_c ≥ q_z, some cell around that line is lower than q_z, and
either it is a 4-neighbour of c or the two cells between them are edge cells containing q); and
only edge cells higher than the own cell (lower, inside) can beat it. So the minimum over the
point's own cell and those edge cells within `reach` horizontally is the exact distance whenever it is
at most `reach`; beyond, the exact distance is at least `reach`, and the value is saturated at
`reach` (gradient 0). Inside, the depth is exact up to `reach` and never underestimated beyond.

Each cell lists those edge cells whose squares lie within `reach` of its square (built once), so
a query costs one distance per candidate: on open ground a point has its own cell only. The grid
is padded by `reach` with copies of its border cells; beyond the padding the terrain is the same
along the outward direction, so a point there is moved onto the padding's outer cell centres without
changing its distance (gradient 0 in that direction).

Unlike the trilinear SDF lookup (`legplan.terrain.sdf`), which reads up to a few millimetres more
than the exact distance beside edges and corners, this value never exceeds the true distance.
"""

from __future__ import annotations

import numpy as np


PAIR_BLOCK = 1 << 20
"""(offset, candidate) combinations `_candidate_pairs` tests at once: bounds its temporary arrays."""


class ColumnDistance:
    """Signed distance to the column solid of `height` (ny, nx), exact up to `reach` (m)."""

    def __init__(self, height, origin, resolution: float, reach: float):
        height = np.asarray(height, dtype=float)
        if height.ndim != 2 or min(height.shape) < 1:
            raise ValueError(f"heightmap must be a 2D array, got shape {height.shape}")
        if not reach > 0:
            raise ValueError(f"reach must be positive, got {reach!r}")
        self.resolution = r = float(resolution)
        self.reach = float(reach)
        pad = int(np.ceil(self.reach / r)) + 1
        padded = np.pad(height, pad, mode="edge")
        self._shape = padded.shape
        self._origin = np.asarray(origin, dtype=float)[:2] - pad * r  # centre of padded cell [0, 0]
        self._last = np.array(padded.shape[::-1]) - 1  # largest (ix, iy)
        self._far = self._origin + r * self._last
        self._height = padded.reshape(-1)
        lower, higher = _neighbour_masks(padded)
        # outside points: edge cells higher than the point's own cell; inside: lower ones (module docstring)
        self._rows, self._tables, self._clear = [], [], []
        for mask, keep in ((lower, np.greater), (higher, np.less)):
            rows, table, clear = _candidate_table(padded, mask, self.reach / r, keep, self._origin, r)
            self._rows.append(rows)
            self._tables.append(table)
            self._clear.append(clear)
        centres, tops = self._tables[0]
        # per row of the outside table: its highest candidate top (a point at z is at least z − top from it)
        self._highest = np.where(centres[..., 0] < 1e8, tops, -np.inf).max(axis=1, initial=-np.inf)

    @classmethod
    def of(cls, terrain, reach: float) -> ColumnDistance:
        """The column distance of a `TerrainMap`."""
        return cls(terrain.height, terrain.grid.origin, terrain.grid.resolution, reach)

    def values(self, points, bound=None) -> np.ndarray:
        """Signed distance (m) at points (n, 3): positive in free space, negative inside terrain.

        With `bound` (n,), the distance is exact where it is below the bound; where it is not, the value
        may be any number ≥ the bound (the search among the neighbouring columns is skipped where a lower
        bound of their distance, the larger of their horizontal gap and the height above the highest
        of them, already reaches `bound`)."""
        return self._evaluate(points, False, bound)[0]

    def value_and_gradient(self, points, bound=None) -> tuple[np.ndarray, np.ndarray]:
        """(values (n,), gradients (n, 3)) of the signed distance at points (n, 3), saturated at `reach`
        (`bound` as in `values`; the gradient of a value that is not exact is not either).

        The gradient is the unit vector from the nearest point (p − q)/‖p − q‖ outside and its
        negative inside (−∇ of the depth); (0, 0, 1) on the surface itself; 0 where saturated.
        """
        return self._evaluate(points, True, bound)

    def _evaluate(self, points, gradient: bool, bound=None):
        p = np.asarray(points, dtype=float).reshape(-1, 3)
        raw = np.rint((p[:, :2] - self._origin) / self.resolution).astype(np.intp)
        g = np.minimum(np.maximum(raw, 0), self._last)
        own = g[:, 1] * self._shape[1] + g[:, 0]
        value = p[:, 2] - self._height[own]  # the own column, straight below (above) the point
        grad = None
        if gradient:
            grad = np.zeros((len(p), 3))
            grad[:, 2] = 1.0
        # a candidate can beat the own column only if the vertical gap exceeds its horizontal one (which also
        # says on which side the point is: above its column for the first table, below for the second)
        for side, (rows, table, clear) in enumerate(zip(self._rows, self._tables, self._clear, strict=True)):
            near = np.flatnonzero((-value if side else value) > clear[own])
            if bound is not None and not side and near.size:
                lower = np.maximum(clear[own[near]], p[near, 2] - self._highest[rows[own[near]]])
                near = near[np.minimum(value[near], lower) < bound[near]]
            if near.size:
                xy = np.minimum(np.maximum(p[near, :2], self._origin), self._far)
                value[near], found = _nearest(xy, p[near, 2], table, rows[own[near]], value[near], self.resolution,
                                              gradient)
                if gradient:
                    grad[near] = found
                    grad[near, :2] *= raw[near] == g[near]  # 0 along a direction in which the point was moved
        far = value > self.reach
        if far.any():
            value[far] = self.reach
            if gradient:
                grad[far] = 0.0
        return value, grad

def _nearest(xy, z, table, rows, own, r: float, gradient: bool = True):
    """Signed distance and gradient (None without `gradient`) of points (xy (m, 2), z (m,)) over their
    own column (signed vertical gap `own`) and the candidate columns of their `rows` of `table`
    (centres, tops)."""
    centres, tops = table
    lateral = xy[:, None, :] - centres[rows]
    gap = np.abs(lateral)
    gap -= 0.5 * r
    np.maximum(gap, 0.0, out=gap)
    side = np.where(own < 0.0, -1.0, 1.0)  # inside: distance to the air above the candidates
    vertical = z[:, None] - tops[rows]
    vertical *= side[:, None]
    np.maximum(vertical, 0.0, out=vertical)
    d2 = gap[..., 0] ** 2 + gap[..., 1] ** 2 + vertical ** 2
    k = np.argmin(d2, axis=1)
    m = np.arange(len(k))
    best = d2[m, k]
    better = best < own ** 2
    dist = np.where(better, np.sqrt(best), np.abs(own))
    if not gradient:
        return side * dist, None
    vector = np.zeros((len(k), 3))  # p − q of the nearest point q (own column: straight up/down)
    vector[:, :2] = np.copysign(gap[m, k], lateral[m, k]) * better[:, None]
    vector[:, 2] = np.where(better, side * vertical[m, k], own)
    grad = np.where(dist[:, None] > 0, vector / np.maximum(dist, 1e-300)[:, None], [0.0, 0.0, 1.0])
    grad *= side[:, None]
    return side * dist, grad


def _candidate_table(height, mask, reach_cells: float, keep, origin, r: float):
    """Per cell of the flat grid, the row (-1: none) of its candidates in a table (centres (rows, K,
    2), tops (rows, K)) padded with columns 1e9 m away, and the smallest horizontal distance (m)
    between the cell's square and a candidate's (inf: none); see `_candidate_pairs`."""
    cells, candidates, gaps = _candidate_pairs(height, mask, reach_cells, keep)
    clear = np.full(height.size, np.inf)
    np.minimum.at(clear, cells, r * gaps)
    order = np.argsort(cells, kind="stable")
    cells, candidates = cells[order], candidates[order]
    first = np.flatnonzero(np.concatenate(([True], cells[1:] != cells[:-1]))) if cells.size else np.zeros(0, np.intp)
    owners, counts = cells[first], np.diff(np.append(first, cells.size))  # runs of the sorted cells
    rows = np.full(height.size, -1, np.intp)
    rows[owners] = np.arange(len(owners))
    width = int(counts.max(initial=0))
    at = np.repeat(np.arange(len(owners)) * width - first, counts) + np.arange(len(cells))  # row · width + slot
    centres = np.full((len(owners), width, 2), 1e9)
    tops = np.zeros((len(owners), width))
    ny, nx = height.shape  # each cell's centre, origin + r · (ix, iy), looked up by its flat index
    centres.reshape(-1, 2)[at, 0] = np.tile(origin[0] + r * np.arange(nx), ny)[candidates]
    centres.reshape(-1, 2)[at, 1] = np.repeat(origin[1] + r * np.arange(ny), nx)[candidates]
    tops.reshape(-1)[at] = height.reshape(-1)[candidates]
    return rows, (centres, tops), clear


def _neighbour_masks(height: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Cells with a strictly lower, and with a strictly higher, 4-neighbour."""
    lower = np.zeros(height.shape, bool)
    higher = np.zeros(height.shape, bool)
    for axis in (0, 1):
        a = [slice(None)] * 2
        b = [slice(None)] * 2
        a[axis], b[axis] = slice(1, None), slice(None, -1)
        a, b = tuple(a), tuple(b)
        lower[a] |= height[b] < height[a]
        lower[b] |= height[a] < height[b]
        higher[a] |= height[b] > height[a]
        higher[b] |= height[a] > height[b]
    return lower, higher


def _candidate_pairs(height: np.ndarray, mask: np.ndarray, reach_cells: float, keep):
    """(cell, candidate) index pairs of the flat grid and the distance of their squares (in cells):
    candidates are `mask` cells whose square lies within `reach_cells` cell sizes of the cell's
    square and whose height h_c passes keep(h_c, h_cell) (the own cell is excluded: every query
    adds it). Pairs come offset by offset (dy, then dx, ascending), each offset's in row-major
    order of the candidates; the offsets are handled in groups of whole arrays, not one by one."""
    ny, nx = mask.shape
    k = int(np.ceil(reach_cells)) + 1
    my, mx = np.nonzero(mask)  # the candidates, in row-major order
    offsets = [(dy, dx, np.hypot(max(abs(dx) - 1, 0), max(abs(dy) - 1, 0)))
               for dy in range(-k, k + 1) for dx in range(-k, k + 1) if dx or dy]
    offsets = [o for o in offsets if not o[2] > reach_cells] if len(my) else []
    cells, candidates, gaps = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    flat = height.reshape(-1)
    own = my.astype(np.int64) * nx + mx  # the candidates' flat indices and heights
    tops = flat[own]
    group = max(1, PAIR_BLOCK // max(len(my), 1))  # offsets per group: a bounded (offsets × candidates) block
    for start in range(0, len(offsets), group):
        dy, dx, gap = (np.array(v) for v in zip(*offsets[start:start + group]))
        # cells (iy, ix) whose neighbour (iy + dy, ix + dx) is a candidate
        inside = ((my >= dy[:, None]) & (my < ny + dy[:, None]) & (mx >= dx[:, None]) & (mx < nx + dx[:, None]))
        o, c = np.nonzero(inside)  # offset-major, candidates in row-major order within an offset
        cell = own[c] - (dy * nx + dx)[o]  # flat index of (iy − dy, ix − dx): inside the grid
        ok = keep(tops[c], flat[cell])
        cells.append(cell[ok])
        candidates.append(own[c[ok]])
        gaps.append(gap[o[ok]])
    return np.concatenate(cells), np.concatenate(candidates), np.concatenate(gaps)
