"""Traditional grid A* (the paper's comparison front end, Sec. V-B): 8-connected, costmap-aware.

Cells are nodes; a move to one of the 8 neighbours costs its length L (R or √2·R) times
(1 + ρ_c·F(target cell)), the same collision weighting as eq. (14) along the path. Cells whose 3×3
block holds a lethal cell (`NavGrid.blocked_at`) are impassable, so the straight segments between
cell centres keep out of lethal cells as the kinodynamic primitives do. The octile distance is an
admissible and consistent heuristic (F ≥ 0). The open list uses lazy deletion like kinoastar.

The position-only path (collinear runs merged) is time-parametrized with a per-segment trapezoidal
profile under the same per-axis limits (`trapezoidal_polyline`), so effort and duration compare
with the kinodynamic trajectory and the TEB refinement can start from either.
"""

from __future__ import annotations

import heapq
import math
import time

import numpy as np

from legplan.nav.collision import NavGrid
from legplan.nav.params import NavParams
from legplan.nav.result import SearchResult, endpoint_problem
from legplan.nav.trajectory import trapezoidal_polyline

PLANNER = "astar"
_SQRT2 = math.sqrt(2.0)


def grid_graph(grid: NavGrid, rho_c: float):
    """Neighbour offsets in the flat (ny, nx) index, their row/column steps, lengths (m), and the
    per-cell multiplier (1 + ρ_c F) with impassable cells set to infinity."""
    ny, nx = grid.shape
    steps = [(dy, dx) for dy in (-1, 0, 1) for dx in (-1, 0, 1) if (dy, dx) != (0, 0)]
    lengths = [grid.resolution * (_SQRT2 if dy and dx else 1.0) for dy, dx in steps]
    iy, ix = np.mgrid[0:ny, 0:nx]
    blocked = grid.blocked_at(grid.frame.cell_center(iy, ix))
    factor = np.where(blocked, np.inf, 1.0 + rho_c * grid.costmap)
    return steps, lengths, factor


def plan_grid(grid: NavGrid, start, goal, params: NavParams = NavParams(),
              progress=None) -> SearchResult:
    """Grid A* from the start cell to the goal cell; the path runs start → cell centres → goal."""
    clock = time.perf_counter()
    start = np.asarray(start, float).reshape(4)
    goal = np.asarray(goal, float).reshape(4)

    def finish(success, reason, expansions, cost=float("nan"), trajectory=None, waypoints=None):
        return SearchResult(success, reason, PLANNER, start, goal, expansions,
                            time.perf_counter() - clock, cost, trajectory, waypoints)

    problem = endpoint_problem(grid, start, goal, params.v_max)
    if problem:
        return finish(False, problem, 0)
    ny, nx = grid.shape
    steps, lengths, factor = grid_graph(grid, params.rho_c)
    factor_list = factor.ravel().tolist()
    (sy,), (sx,), _ = grid.frame.cell_of(start[:2])
    (gy,), (gx,), _ = grid.frame.cell_of(goal[:2])
    source, target = int(sy * nx + sx), int(gy * nx + gx)
    res = grid.resolution
    diag = (_SQRT2 - 1.0) * res

    def octile(cell):
        dy, dx = abs(cell // nx - gy), abs(cell % nx - gx)
        return res * max(dx, dy) + diag * min(dx, dy)

    moves = [(dy * nx + dx, dy, dx, length) for (dy, dx), length in zip(steps, lengths)]
    g_best = {source: 0.0}
    parent = {source: -1}
    heap = [(octile(source), 0.0, source)]
    closed = set()
    expansions = 0
    budget = params.expansion_budget(ny * nx)
    while heap:
        _, g, cell = heapq.heappop(heap)
        if cell in closed or g > g_best[cell]:
            continue
        closed.add(cell)
        expansions += 1
        if cell == target:
            cells = _path(parent, target)
            centres = grid.frame.cell_center(np.array(cells) // nx, np.array(cells) % nx)
            waypoints = _merge_collinear(np.vstack([start[:2], centres[1:-1], goal[:2]])
                                         if len(cells) > 1 else np.vstack([start[:2], goal[:2]]))
            trajectory = trapezoidal_polyline(waypoints, params.v_max, params.a_max)
            return finish(True, "", expansions, g, trajectory, waypoints)
        if expansions >= budget:
            return finish(False, f"expansion limit ({budget}) reached", expansions)
        if progress is not None and expansions % 20000 == 0:
            progress(expansions, budget, "")
        row, col = divmod(cell, nx)
        for offset, dy, dx, length in moves:
            r, c = row + dy, col + dx
            if r < 0 or c < 0 or r >= ny or c >= nx:
                continue
            child = cell + offset
            g_child = g + length * factor_list[child]
            if g_child >= g_best.get(child, math.inf) or child in closed:
                continue
            g_best[child] = g_child
            parent[child] = cell
            heapq.heappush(heap, (g_child + octile(child), g_child, child))
    return finish(False, "goal unreachable (open list exhausted)", expansions)


def _path(parent: dict, target: int) -> list[int]:
    cells = [target]
    while parent[cells[-1]] >= 0:
        cells.append(parent[cells[-1]])
    return cells[::-1]


def _merge_collinear(points: np.ndarray) -> np.ndarray:
    """Drop interior vertices where the direction does not change (runs of equal grid moves)."""
    keep = [0]
    for i in range(1, len(points) - 1):
        a, b = points[i] - points[keep[-1]], points[i + 1] - points[i]
        if abs(a[0] * b[1] - a[1] * b[0]) > 1e-12 or a @ b <= 0:
            keep.append(i)
    keep.append(len(points) - 1)
    return points[keep]
