"""Kinodynamic A* (Sec. III): search over constant-input primitives with the LQMT heuristic.

Nodes are states x = [p, ṗ] (eq. (2)); children come from every input of the lattice applied for τ
(eq. (6)), cost g accumulates (||u_m||² + ρ)τ + ρ_c·c_collision (eqs. (8), (19)); f = g + w·h with
h = J*(T_h) (eqs. (9)–(12), `heuristic.py`). States are hashed on a position-velocity grid
(`pos_res`, `vel_res`); a cell keeps the cheapest state that reached it, is expanded at most once
(closed set), and the open list is a `heapq` with lazy deletion: an improved node is pushed again
and stale entries (g above the node's best) are skipped on pop, so heap keys are never mutated.

Analytic expansion: a node within `oneshot_radius` of the goal tries the optimal cubic of eq. (9)
with T = T_h straight to the goal state; it is accepted when its samples are collision-free and
its velocity and acceleration extrema are within the limits.
"""

from __future__ import annotations

import heapq
import logging
import time

import numpy as np

from legplan.nav.collision import NavGrid
from legplan.nav.heuristic import ChildHeuristic, min_time_cost, optimal_polynomial
from legplan.nav.params import NavParams
from legplan.nav.primitives import PrimitiveSet, sample_count
from legplan.nav.result import SearchResult, endpoint_problem
from legplan.nav.trajectory import Trajectory

log = logging.getLogger(__name__)

PLANNER = "kinoastar"


def plan_kinodynamic(grid: NavGrid, start, goal, params: NavParams = NavParams(),
                     progress=None) -> SearchResult:
    """Plan from `start` to `goal` (px, py, vx, vy) on `grid`; never raises for planning failures."""
    clock = time.perf_counter()
    start = np.asarray(start, float).reshape(4)
    goal = np.asarray(goal, float).reshape(4)

    def finish(success, reason, expansions, cost=float("nan"), trajectory=None):
        return SearchResult(success, reason, PLANNER, start, goal, expansions,
                            time.perf_counter() - clock, cost, trajectory)

    problem = endpoint_problem(grid, start, goal, params.v_max)
    if problem:
        return finish(False, problem, 0)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        return _search(grid, start, goal, params, progress, finish)


def _search(grid, start, goal, params, progress, finish):
    prims = PrimitiveSet.build(params.mu, params.a_max, params.tau, params.v_max,
                               grid.resolution, params.rho)
    pg, vg = goal[:2], goal[2:]
    rho, v_max, rho_c, weight = params.rho, params.v_max, params.rho_c, params.weight
    bound = v_max if params.time_bound else None
    heuristic = ChildHeuristic(prims.inputs, prims.tau, pg, vg, rho, bound)
    encode = _KeyEncoder(grid, params)
    oneshot_r2 = params.oneshot_radius ** 2
    tol, vtol = params.goal_tolerance, params.goal_vel_tolerance
    check_tolerance = tol > 0 or vtol > 0

    start_key = encode.one(start[:2], start[2:])
    # node: (g, parent key, input index, end positions, end velocities, row) — the state is
    # row `row` of the batch arrays produced when the node was generated.
    nodes = {start_key: (0.0, None, -1, start[None, :2], start[None, 2:], 0)}
    h0 = float(min_time_cost(start[:2], start[2:], pg, vg, rho, bound)[0])
    heap = [(weight * h0, 0.0, start_key)]
    closed = set()
    expansions = 0
    heappush, heappop = heapq.heappush, heapq.heappop
    while heap:
        _, g, key = heappop(heap)
        if key in closed:
            continue
        node = nodes[key]
        if g > node[0]:
            continue
        closed.add(key)
        expansions += 1
        p, v = node[3][node[5]], node[4][node[5]]
        if check_tolerance and np.max(np.abs(p - pg)) <= tol and np.max(np.abs(v - vg)) <= vtol:
            return finish(True, "", expansions, g, _reconstruct(nodes, key, prims, None))
        delta = p - pg
        if delta[0] * delta[0] + delta[1] * delta[1] <= oneshot_r2:
            shot = analytic_expansion(grid, p, v, pg, vg, params)
            if shot is not None:
                piece, shot_cost = shot
                return finish(True, "", expansions, g + shot_cost,
                              _reconstruct(nodes, key, prims, piece))
        if expansions >= params.max_expansions:
            return finish(False, f"expansion limit ({params.max_expansions}) reached", expansions)
        if progress is not None and expansions % 2000 == 0:
            progress(expansions, params.max_expansions, f"g={g:.1f}")
        end_p, end_v, cost, feasible = prims.expand(grid, p, v, v_max, rho_c)
        rows = np.flatnonzero(feasible).tolist()
        if not rows:
            continue
        g_children = g + cost
        f_children = (g_children + weight * heuristic(p, v)).tolist()
        keys = encode.many(end_p, end_v).tolist()
        g_children = g_children.tolist()
        for row in rows:
            child = keys[row]
            if child in closed:
                continue
            g_child = g_children[row]
            old = nodes.get(child)
            if old is not None and old[0] <= g_child:
                continue
            nodes[child] = (g_child, key, row, end_p, end_v, row)
            heappush(heap, (f_children[row], g_child, child))
    return finish(False, "goal unreachable (open list exhausted)", expansions)


class _KeyEncoder:
    """One Python int per hash cell: (ix, iy) of `pos_res`, (ivx, ivy) of `vel_res`."""

    def __init__(self, grid: NavGrid, params: NavParams):
        xmin, xmax, ymin, ymax = grid.extent
        self.origin = np.array([xmin, ymin])
        self.inv_p = 1.0 / params.pos_res
        self.inv_v = 1.0 / params.vel_res
        self.vel_span = 2 * int(np.ceil(params.v_max * self.inv_v)) + 3
        self.vel_offset = self.vel_span // 2
        self.ny = int(np.ceil((ymax - ymin) * self.inv_p)) + 2

    def many(self, p: np.ndarray, v: np.ndarray) -> np.ndarray:
        ip = np.floor((p - self.origin) * self.inv_p).astype(np.int64)
        iv = np.rint(v * self.inv_v).astype(np.int64) + self.vel_offset
        return ((ip[:, 0] * self.ny + ip[:, 1]) * self.vel_span + iv[:, 0]) * self.vel_span + iv[:, 1]

    def one(self, p: np.ndarray, v: np.ndarray) -> int:
        return int(self.many(p[None], v[None])[0])


ONESHOT_STRETCH = (1.0, 1.25, 1.5, 2.0, 3.0)


def analytic_expansion(grid: NavGrid, p, v, pg, vg, params: NavParams):
    """The one-shot cubic of eq. (9) from (p, v) to (pg, vg), or None if infeasible.

    Tries T = T_h (the minimizer of J*, eq. (11)) first; when that cubic breaks a velocity or
    acceleration limit — J*'s optimum balances ||a||² against ρ and ignores the limits — the
    duration is stretched by the factors `ONESHOT_STRETCH` (J*(T) ≥ J*(T_h), so h stays a lower
    bound). Returns ((p0, v0, a0, jerk, T), cost) with cost = J*(T) + ρ_c·c_collision.
    """
    bound = params.v_max if params.time_bound else None
    T_h = float(min_time_cost(p, v, pg, vg, params.rho, bound)[1])
    if T_h <= 1e-6:
        return None
    for factor in ONESHOT_STRETCH:
        shot = _oneshot(grid, p, v, pg, vg, T_h * factor, params)
        if shot is not None:
            return shot
    return None


def _oneshot(grid, p, v, pg, vg, T, params):
    """Check the eq. (9) cubic of duration T: acceleration is linear in t (extrema at the ends),
    velocity quadratic (ends and the vertex t = -β/α); collision on the dense samples."""
    alpha, beta = optimal_polynomial(p, v, pg, vg, T)
    if np.max(np.abs(beta)) > params.a_max + 1e-9 or \
            np.max(np.abs(beta + alpha * T)) > params.a_max + 1e-9:
        return None
    vertex = np.clip(np.divide(-beta, alpha, out=np.zeros(2), where=alpha != 0.0), 0.0, T)
    v_vertex = v + vertex * (beta + 0.5 * alpha * vertex)
    if np.max(np.abs(v_vertex)) > params.v_max + 1e-9:
        return None
    t = np.linspace(0.0, T, sample_count(params.v_max, T, grid.resolution))[:, None]
    positions = p + t * (v + t * (0.5 * beta + t * alpha / 6.0))
    index = grid.flat_index(positions)
    if grid.blocked_flat[index].any():
        return None
    velocities = v + t * (beta + 0.5 * t * alpha)
    effort = float(np.sum(beta**2 * T + alpha * beta * T**2 + alpha**2 * T**3 / 3.0))
    collision = float(np.sum(grid.cost_flat[index] * np.linalg.norm(velocities, axis=1))) \
        * T / (len(t) - 1)
    cost = effort + params.rho * T + params.rho_c * collision
    return (p, v, beta, alpha, T), cost


def _reconstruct(nodes, key, prims: PrimitiveSet, last_piece) -> Trajectory:
    """Follow parents from `key` back to the start; primitives then the optional one-shot."""
    pieces = [] if last_piece is None else [last_piece]
    zero = np.zeros(2)
    while True:
        _, parent, prim, _, _, _ = nodes[key]
        if parent is None:
            break
        parent_node = nodes[parent]
        p0 = parent_node[3][parent_node[5]]
        v0 = parent_node[4][parent_node[5]]
        pieces.append((p0, v0, prims.inputs[prim], zero, prims.tau))
        key = parent
    if not pieces:
        node = nodes[key]
        pieces.append((node[3][node[5]], node[4][node[5]], zero, zero, 0.0))
    return Trajectory.from_pieces(reversed(pieces))
