"""`NavGrid`: the search's view of a map's navigation layers (occupancy-derived distance, costmap).

Hard constraint (Sec. III-C). A cell is *lethal* when its distance to the nearest obstacle is below
the inscribed radius l1 (there the costmap holds C_max, eq. (15)); cells outside the map are
lethal too. Trajectories are sampled so that consecutive samples are at most one cell apart per
axis, and a sample is rejected when any lethal cell lies in the 3×3 block around its cell
(`blocked`, the lethal mask dilated by one cell). Between two samples every point lies within half
a cell (per axis) of one of them, so it lies in that sample's 3×3 block: the continuous trajectory
never enters a lethal cell, at the price of one cell of extra margin.

Soft constraint (Sec. III-D): `cost` is the costmap value F(s) of eqs. (15)–(16), read at the same
samples for the collision cost of eq. (18). `hard_cost_flat` merges both for the search: F(s), or
+inf where the sample is blocked, so one gather gives the collision sum and its feasibility.

Lookups are flat gathers into arrays padded by one lethal cell on every side, with indices clipped
into the padding, so points outside the map read as lethal without a bounds branch.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from legplan.errors import LegplanError
from legplan.terrain.grid import Grid2D


@dataclass(frozen=True)
class NavGrid:
    """Costmap F (ny, nx), distance field (ny, nx) in m, lethal radius l1, origin of cell [0, 0]'s
    centre (x0, y0) in m, square cell size `resolution` in m. Row index is y, column index is x."""

    costmap: np.ndarray
    distance: np.ndarray
    l1: float
    origin: tuple[float, float]
    resolution: float
    frame: Grid2D = field(init=False, repr=False)  # origin, resolution, shape: extent and cell lookups
    lethal: np.ndarray = field(init=False, repr=False)  # (ny, nx) distance < l1
    # Padded (ny + 2) * (nx + 2) flat arrays indexed by `flat_index` (hot-path gathers).
    blocked_flat: np.ndarray = field(init=False, repr=False)
    cost_flat: np.ndarray = field(init=False, repr=False)
    hard_cost_flat: np.ndarray = field(init=False, repr=False)  # cost_flat, +inf where blocked
    _free_graph: list = field(default_factory=list, init=False, repr=False, compare=False)
    distance_flat: np.ndarray = field(init=False, repr=False)

    def __post_init__(self):
        costmap = np.asarray(self.costmap, float)
        distance = np.asarray(self.distance, float)
        if costmap.ndim != 2 or costmap.shape != distance.shape:
            raise LegplanError(f"nav grid: costmap {costmap.shape} and distance {distance.shape} "
                               "must be 2D arrays of the same shape")
        if not self.resolution > 0:
            raise LegplanError(f"nav grid: field 'resolution' must be > 0, got {self.resolution}")
        lethal = distance < self.l1
        blocked = dilate_3x3(np.pad(lethal, 1, constant_values=True))
        blocked[[0, -1], :] = True
        blocked[:, [0, -1]] = True
        setter = object.__setattr__
        setter(self, "costmap", costmap)
        setter(self, "distance", distance)
        setter(self, "origin", (float(self.origin[0]), float(self.origin[1])))
        setter(self, "frame", Grid2D(self.origin, float(self.resolution), costmap.shape))
        setter(self, "lethal", lethal)
        setter(self, "blocked_flat", blocked.ravel())
        setter(self, "cost_flat", np.pad(costmap, 1, mode="edge").ravel())
        setter(self, "hard_cost_flat", np.where(self.blocked_flat, np.inf, self.cost_flat))
        setter(self, "distance_flat", np.pad(distance, 1, constant_values=0.0).ravel())

    @classmethod
    def from_terrain(cls, terrain, lethal_radius: float | None = None) -> NavGrid:
        """The view of a `legplan.terrain.TerrainMap`'s /nav layers; `lethal_radius` (e.g. the
        robot's inscribed radius) raises l1 when larger than the map's costmap l1."""
        l1 = terrain.nav_params.l1 if lethal_radius is None else max(terrain.nav_params.l1,
                                                                       lethal_radius)
        return cls(terrain.costmap, terrain.distance, l1, terrain.grid.origin,
                   terrain.grid.resolution)

    @classmethod
    def from_map(cls, path, lethal_radius: float | None = None) -> NavGrid:
        """Load a map.h5 artefact (`legplan.terrain.load_map`) and view its /nav layers."""
        from legplan.terrain import load_map

        return cls.from_terrain(load_map(path), lethal_radius)

    @property
    def shape(self) -> tuple[int, int]:
        return self.costmap.shape

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the map's cell edges, m (`Grid2D.extent`)."""
        return self.frame.extent

    def to_cells(self, points: np.ndarray) -> np.ndarray:
        """Points (..., 2) in padded-cell units: the cell holding a point is floor of this."""
        return (points - self.origin) * (1.0 / self.resolution) + 1.5

    def flat_index(self, points: np.ndarray) -> np.ndarray:
        """Index into the padded flat arrays of the cell holding each point (..., 2) → (...)."""
        return self.flat_index_cells(self.to_cells(points))

    def flat_index_cells(self, cells: np.ndarray) -> np.ndarray:
        """`flat_index` of points already in padded-cell units (`to_cells`); off-map → padding."""
        ny, nx = self.shape
        index = np.fmin(np.fmax(cells, 0.0), (nx + 1, ny + 1)).astype(np.intp)
        return index[..., 1] * (nx + 2) + index[..., 0]

    def blocked_at(self, points: np.ndarray) -> np.ndarray:
        """True where a point's 3×3 cell block holds a lethal cell or leaves the map (hard)."""
        return self.blocked_flat[self.flat_index(points)]

    def lethal_at(self, points: np.ndarray) -> np.ndarray:
        """True where the point's own cell is lethal or outside the map (no margin)."""
        lethal = np.pad(self.lethal, 1, constant_values=True).ravel()
        return lethal[self.flat_index(points)]

    def cost_at(self, points: np.ndarray) -> np.ndarray:
        """Costmap value F(s) at each point (eq. (15)); outside the map the border value."""
        return self.cost_flat[self.flat_index(points)]

    def clearance_at(self, points: np.ndarray) -> np.ndarray:
        """Distance to the nearest obstacle at each point's cell, m; 0 outside the map."""
        return self.distance_flat[self.flat_index(points)]

    def step_distance(self, point) -> np.ndarray:
        """(ny, nx) number of 8-connected steps from the cell holding `point` to every cell through
        *passable* cells (inf where unreachable, or everywhere if that cell is not passable).

        A cell is passable when a cell of its 3×3 block is not blocked. Every point of a
        trajectory that keeps its samples out of blocked cells lies within half a cell per axis of
        a sample (module doc), so in a passable cell: the trajectories of both planners never
        leave the passable cells. Passable is stricter than not lethal: gaps of 1–2 non-lethal
        cells between lethal ones (narrow alleys, diagonal cracks) are blocked for the planners and
        closed here, so routes do not count on them. Breadth-first search on the grid graph, which
        is built once per grid."""
        from scipy.sparse.csgraph import dijkstra  # the search's BFS only (start-up time)

        if not self._free_graph:
            self._free_graph.extend(self._build_free_graph())
        graph, passable = self._free_graph
        ny, nx = self.shape
        (iy,), (ix,), (inside,) = self.frame.cell_of(np.asarray(point, float))
        if not inside or not passable[iy, ix]:
            return np.full((ny, nx), np.inf)
        steps = dijkstra(graph, directed=False, unweighted=True,
                         indices=int(iy * nx + ix))
        return steps.reshape(ny, nx)

    def _build_free_graph(self):
        """Sparse adjacency of the passable cells (`step_distance`), each linked to its 8
        neighbours, and the (ny, nx) passable mask."""
        from scipy.sparse import coo_matrix

        ny, nx = self.shape
        ids = np.arange(ny * nx).reshape(ny, nx)
        clear = ~self.blocked_flat.reshape(ny + 2, nx + 2)
        free = dilate_3x3(clear)[1:-1, 1:-1]
        rows, cols = [], []
        for dy, dx in ((0, 1), (1, 0), (1, 1), (1, -1)):
            a = (slice(0, ny - dy), slice(max(-dx, 0), nx - max(dx, 0)))
            b = (slice(dy, ny), slice(max(dx, 0), nx - max(-dx, 0)))
            both = free[a] & free[b]
            rows.append(ids[a][both])
            cols.append(ids[b][both])
        rows, cols = np.concatenate(rows), np.concatenate(cols)
        graph = coo_matrix((np.ones(len(rows)), (rows, cols)), shape=(ny * nx, ny * nx)).tocsr()
        return graph, free



def dilate_3x3(mask: np.ndarray) -> np.ndarray:
    """Binary dilation of a 2-D mask by the 3×3 block (cells beyond the border count as False): a
    cell is set when any cell of its 3×3 block is — the 3×3 box done as two 1-D passes."""
    rows = mask.copy()
    rows[1:] |= mask[:-1]
    rows[:-1] |= mask[1:]
    out = rows.copy()
    out[:, 1:] |= rows[:, :-1]
    out[:, :-1] |= rows[:, 1:]
    return out
