"""The terrain as the centroidal optimizer sees it: height, normal basis and distance to edges.

Height h(x, y) is the bilinear interpolation of map.h5's heightmap layer (cell centres), as TOWR's
height maps give a height and its gradient at any (x, y); stance feet stand on it. Swing feet keep
above `envelope`, a bilinear surface that bounds the column terrain of the map's SDF from above. The functions accept complex coordinates
(the cell is chosen from the real part, the interpolation is a polynomial), so the constraint blocks
differentiate them by complex step exactly, including the terrain normal's change with position.

The stair-edge cost (TOWR-costs paper, Sec. III-A-2) needs each foothold's distance to the nearest
terrain edge: cells whose height differs from a 4-neighbour by more than `edge_step` are edges; the
Euclidean distance transform of the non-edge cells, bilinear again, gives that distance.

`stance_slope` is the slope |∇(G_σ * h)| of the heightmap smoothed by a Gaussian of σ =
`SLOPE_SMOOTHING`, sampled at the cells' corners (`corner_slope`) and bilinear between them: near a
step it rises smoothly toward the edge (a 16.5 cm pallet edge on the 1 cm grid: 3.3 on it, 1.5 at
2.5 cm, 0.76 at 3.5 cm, 0.30 at 4.5 cm), so a bound on it keeps stance feet off edges with a gradient
that points away from them, where the raw heightmap's one-cell ramp has none, up to the edge itself:
the step lies on a line of corners, where the slope peaks in one sample.
"""

from __future__ import annotations

import numpy as np

from legplan.cache import filtered
from legplan.terrain import Grid2D, TerrainMap

EDGE_STEP = 0.02  # m: a height jump between neighbouring cells that makes both an edge
SLOPE_SMOOTHING = 0.02  # m: σ of the Gaussian under `stance_slope`


class TerrainModel:
    """Height, gradient, normal basis and edge distance of a heightmap (see module docstring)."""

    def __init__(self, terrain: TerrainMap, edge_step: float = EDGE_STEP):
        self.name = terrain.name
        self.height_grid = np.asarray(terrain.height, float)
        self.grid = terrain.grid
        self.origin = np.asarray(terrain.grid.origin, float)
        self.resolution = float(terrain.grid.resolution)
        self.shape = self.height_grid.shape
        h = self.height_grid
        edge = np.zeros(h.shape, bool)
        jump_x = np.abs(np.diff(h, axis=1)) > edge_step
        jump_y = np.abs(np.diff(h, axis=0)) > edge_step
        edge[:, 1:] |= jump_x
        edge[:, :-1] |= jump_x
        edge[1:, :] |= jump_y
        edge[:-1, :] |= jump_y
        self.has_edges = bool(edge.any())
        self.level = not np.ptp(h) > 0  # no terrain rises anywhere (read by every build of a problem)
        smooth = filtered("gaussian_filter", h, SLOPE_SMOOTHING / self.resolution, mode="nearest")
        self.slope_grid, self.slope_corners = corner_slope(smooth, terrain.grid)
        if self.has_edges:
            self.edge_distance_grid = filtered("distance_transform_edt", ~edge) * self.resolution
        else:
            self.edge_distance_grid = np.full(h.shape, np.inf)

    def contains(self, xy) -> np.ndarray:
        """Whether points (n, 2) lie inside the map's cell-centre rectangle."""
        xy = np.asarray(xy, float).reshape(-1, 2)
        lo = self.origin
        hi = self.origin + self.resolution * (np.array(self.shape[::-1]) - 1)
        return np.all((xy >= lo) & (xy <= hi), axis=1)

    def _bilinear(self, grid: np.ndarray, x, y, gradient: bool = False, frame: Grid2D | None = None):
        """`Grid2D.bilinear` of one of this model's grids at arrays x, y (real or complex), shaped as x,
        on the map's cells or on `frame` (the slope's corner grid). A grid of one finite value (a
        level map's height, envelope and slope) is that value with zero gradient everywhere, without
        the interpolation (whose weights sum to one up to rounding)."""
        shape = np.shape(x)
        constant = self._constant_value(grid)
        if constant is not None:
            value = np.full(shape, constant, dtype=np.result_type(x, y, float))
            return (value, np.zeros(shape), np.zeros(shape)) if gradient else value
        out = (frame or self.grid).bilinear(grid, np.stack([np.ravel(x), np.ravel(y)], axis=-1), gradient)
        if not gradient:
            return out.reshape(shape)
        value, g = out
        return value.reshape(shape), g[:, 0].reshape(shape), g[:, 1].reshape(shape)

    def _constant_value(self, grid: np.ndarray) -> float | None:
        """The one value of a grid of this model whose cells all hold the same finite number (None
        otherwise), judged once per grid (the model's grids are never modified)."""
        known = self.__dict__.setdefault("_constants", {})
        if id(grid) not in known or known[id(grid)][0] is not grid:
            flat = grid.ravel()
            one = flat.size and np.isfinite(flat[0]) and not np.any(flat != flat[0])
            known[id(grid)] = (grid, float(flat[0]) if one else None)
        return known[id(grid)][1]

    def height(self, x, y):
        """h(x, y) for arrays x, y (real or complex)."""
        return self._bilinear(self.height_grid, x, y)

    def envelope(self, x, y):
        """An upper bound of the column terrain (each cell a flat column, the model of the map's SDF):
        the bilinear interpolation of the 3 × 3 maximum-filtered heightmap (`envelope_within` 0). The
        four cell centres around a point are neighbours of the cell that contains it, so every
        interpolated value is at least that cell's height. Swing feet are kept above this surface."""
        return self.envelope_within(0.0)(x, y)

    def envelope_within(self, radius: float):
        """An upper bound h̄_r of the column terrain within `radius` (m) of (x, y) horizontally, as
        a function of arrays x, y (real or complex): the bilinear interpolation of the heightmap
        maximum-filtered, at each cell centre, over every cell whose square comes within radius +
        √2 cells of it (a cell within `radius` of a point is within that of each of the four cell
        centres around the point; radius 0 is the 3 × 3 neighbourhood). A sphere of that radius whose
        centre is its radius above h̄_r clears every column. The filtered grid is kept per radius."""
        grid = self._envelope_grid(radius)
        return lambda x, y: self._bilinear(grid, x, y)

    def envelope_gradient(self, x, y):
        """(h̄, ∂h̄/∂x, ∂h̄/∂y) of `envelope` at (x, y), real."""
        return self._bilinear(self._envelope_grid(0.0), x, y, gradient=True)

    def _envelope_grid(self, radius: float) -> np.ndarray:
        """The maximum-filtered heightmap under `envelope_within(radius)`, kept per radius."""
        grids = self.__dict__.setdefault("_envelopes", {})
        if radius not in grids:
            reach = radius / self.resolution + np.sqrt(2.0)
            span = int(np.floor(reach + 0.5))
            i, j = np.abs(np.mgrid[-span:span + 1, -span:span + 1])
            footprint = np.hypot(np.maximum(i - 0.5, 0.0), np.maximum(j - 0.5, 0.0)) <= reach
            grids[radius] = filtered("maximum_filter", self.height_grid, footprint=footprint, mode="nearest")
        return grids[radius]

    def column_distance(self, reach: float):
        """The exact signed distance to the column solid of the heightmap, exact up to `reach` (m)
        (`legplan.terrain.columns.ColumnDistance`: value and gradient), built once per reach."""
        from legplan.terrain.columns import ColumnDistance

        built = self.__dict__.setdefault("_columns", {})
        if reach not in built:
            built[reach] = ColumnDistance(self.height_grid, self.origin, self.resolution, reach)
        return built[reach]

    def height_gradient(self, x, y):
        """(h, ∂h/∂x, ∂h/∂y) at (x, y), real or complex."""
        return self._bilinear(self.height_grid, x, y, gradient=True)

    def basis(self, x, y):
        """Unit normal n and tangents t1, t2 (each (n, 3)) of the terrain at (x, y), as TOWR's height
        maps: n ∝ (−h_x, −h_y, 1), t1 ∝ (1, 0, h_x), t2 ∝ (0, 1, h_y)."""
        _, hx, hy = self.height_gradient(x, y)
        one, zero = np.ones_like(hx), np.zeros_like(hx)
        n = np.stack([-hx, -hy, one], axis=-1)
        t1 = np.stack([one, zero, hx], axis=-1)
        t2 = np.stack([zero, one, hy], axis=-1)
        unit = lambda a: a / np.sqrt(np.sum(a * a, axis=-1, keepdims=True))  # holomorphic norm
        return unit(n), unit(t1), unit(t2)

    def stance_slope(self, x, y):
        """Slope of the Gaussian-smoothed heightmap at (x, y) (module docstring), real or complex."""
        return self._bilinear(self.slope_grid, x, y, frame=self.slope_corners)

    def stance_slope_gradient(self, x, y):
        """(slope, ∂/∂x, ∂/∂y) of `stance_slope` at (x, y), real."""
        return self._bilinear(self.slope_grid, x, y, gradient=True, frame=self.slope_corners)

    def edge_distance(self, x, y):
        """Distance (m) from (x, y) to the nearest edge cell (inf on a map without edges)."""
        return self._bilinear(self.edge_distance_grid, x, y)


def corner_slope(smooth: np.ndarray, grid: Grid2D) -> tuple[np.ndarray, Grid2D]:
    """|∇s| of a cell-centred field s (the smoothed heightmap) at the cells' corners, and the grid of
    those corners (module docstring): each component the mean of the two differences of s across the
    corner along its axis, the field repeated one cell beyond the border (the smoothing's "nearest"
    mode, so nothing slopes across the border). A heightmap's step lies between two cell centres,
    on a line of corners, and its smoothed slope peaks there: sampled at the corners the peak is one
    sample and the interpolated slope falls away from it on both sides, where samples at the two
    centres beside the step hold the same value and their interpolation is flat over the cell
    between them, a crest with no gradient off it."""
    r = float(grid.resolution)
    padded = np.pad(np.asarray(smooth, float), 1, mode="edge")
    dx = np.diff(padded, axis=1) / r
    dy = np.diff(padded, axis=0) / r
    gx = 0.5 * (dx[1:] + dx[:-1])
    gy = 0.5 * (dy[:, 1:] + dy[:, :-1])
    corners = Grid2D(origin=(grid.origin[0] - 0.5 * r, grid.origin[1] - 0.5 * r), resolution=r,
                     shape=(grid.shape[0] + 1, grid.shape[1] + 1))
    return np.hypot(gx, gy), corners
