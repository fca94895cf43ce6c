"""Kinodynamic A* (Sec. III): search over constant-input primitives with the LQMT heuristic.

Nodes are states x = [p, ṗ] (eq. (2)); children come from every input of the lattice applied for τ
(eq. (6)), cost g accumulates (||u_m||² + ρ)τ + ρ_c·c_collision (eqs. (8), (19)); f = g + w·h with
h = J*(T_h) (eqs. (9)–(12), `heuristic.py`). States are hashed on a position-velocity grid
(`pos_res`, `vel_res`); a cell keeps the cheapest state that reached it, is expanded at most once
(closed set), and the open list is a `heapq` with lazy deletion: an improved node is pushed again
and stale entries (g above the node's best) are skipped on pop, so heap keys are never mutated.

One expansion: `PrimitiveSet.expand` evaluates all children at once in numpy (samples, hard
constraints, edge costs, end states), `_KeyEncoder` hashes them in the same batch, and a short
Python loop drops the children whose cell is closed or already reached at most as cheaply. Only
the survivors — a few of the (2μ+1)² children — get their heuristic, one scalar evaluation each.

Analytic expansion: a node within `oneshot_radius` of the goal tries the optimal cubic of eq. (9)
with T = T_h straight to the goal state; it is accepted when its samples are collision-free and
its velocity and acceleration extrema are within the limits.
"""

from __future__ import annotations

import heapq
import logging
import math
import time

import numpy as np

from legplan.nav.collision import NavGrid
from legplan.nav.heuristic import GeodesicTimeBound, GoalHeuristic, optimal_polynomial
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
    """Weighted A* with `params.weight`, restarted with the next weight of `RESTART_WEIGHTS` when a
    stage spends `STAGE_EXPANSIONS_PER_STEP` expansions per route step (geodesic bound only); the
    last stage has the rest of the budget."""
    prims = PrimitiveSet.build(params, grid)
    floor = GeodesicTimeBound(grid, goal[:2], params.v_max, params.tau) \
        if params.geodesic_bound else None
    budget = params.expansion_budget(grid.shape[0] * grid.shape[1])
    weights, stage = [params.weight], budget
    if floor is not None:
        steps = floor.route_steps(start[0], start[1])
        if not math.isfinite(steps):
            return finish(False, "goal unreachable (no route through passable cells)", 0)
        if params.restarts:
            weights = [params.weight * factor for factor in RESTART_WEIGHTS]
            stage = max(int(STAGE_EXPANSIONS_PER_STEP * steps), MIN_STAGE_EXPANSIONS)
    heuristic = GoalHeuristic(goal[:2], goal[2:], params.rho,
                              params.v_max if params.time_bound else None, floor)
    used = 0
    for index, weight in enumerate(weights):
        limit = budget - used if index == len(weights) - 1 else min(stage, budget - used)
        outcome = _weighted_search(grid, start, goal, params, prims, heuristic, weight, limit,
                                   progress)
        used += outcome[2]
        if outcome[0] or "expansion limit" not in outcome[1] or used >= budget:
            break
        log.info("kinoastar: %d expansions with weight %g, restarting with weight %g", used,
                 weight, weights[index + 1])
    success, reason, _, cost, trajectory = outcome
    if "expansion limit" in reason:
        reason = f"expansion limit ({budget}) reached"
    return finish(success, reason, used, cost, trajectory)


def _weighted_search(grid, start, goal, params, prims, heuristic, weight, budget, progress):
    """One weighted A* search: (success, reason, expansions, cost, trajectory)."""

    def finish(success, reason, expansions, cost=float("nan"), trajectory=None):
        return success, reason, expansions, cost, trajectory

    encode = _KeyEncoder(grid, params)
    gx, gy, gvx, gvy = goal.tolist()
    oneshot_r2 = params.oneshot_radius ** 2
    tol, vtol = params.goal_tolerance, params.goal_vel_tolerance
    check_tolerance = tol > 0 or vtol > 0
    inf = math.inf

    state = tuple(start.tolist())
    start_key = encode(start[:, None]).tolist()[0]
    # best[key]: g of the cheapest state reaching the cell, -inf once the cell is closed.
    # nodes[key]: (parent key, input index, (px, py, vx, vy)) of that state.
    best = {start_key: 0.0}
    nodes = {start_key: (None, -1, state)}
    heap = [(weight * heuristic(*state)[0], 0.0, start_key)]
    expansions = 0
    heappush, heappop, best_get = heapq.heappush, heapq.heappop, best.get
    while heap:
        _, g, key = heappop(heap)
        if best[key] != g:  # closed, or a stale entry of a since improved cell
            continue
        best[key] = -inf
        expansions += 1
        px, py, vx, vy = state = nodes[key][2]
        if check_tolerance and max(abs(px - gx), abs(py - gy)) <= tol and \
                max(abs(vx - gvx), abs(vy - gvy)) <= vtol:
            return finish(True, "", expansions, g, _reconstruct(nodes, key, prims, None))
        if (px - gx) ** 2 + (py - gy) ** 2 <= oneshot_r2:
            shot = analytic_expansion(grid, np.array(state[:2]), np.array(state[2:]),
                                      goal[:2], goal[2:], heuristic(*state)[1], params)
            if shot is not None:
                piece, shot_cost = shot
                return finish(True, "", expansions, g + shot_cost,
                              _reconstruct(nodes, key, prims, piece))
        if expansions >= budget:
            return finish(False, f"expansion limit ({budget}) reached", expansions)
        if progress is not None and expansions % 2000 == 0:
            progress(expansions, budget, f"g={g:.1f}")
        children, feasible = prims.expand(px, py, vx, vy)
        rows = feasible.nonzero()[0].tolist()
        if not rows:
            continue
        keys = encode(children[:4]).tolist()
        end_px, end_py, end_vx, end_vy, cost = children.tolist()
        for row in rows:
            child, g_child = keys[row], g + cost[row]
            if best_get(child, inf) <= g_child:  # closed, or reached at least as cheaply
                continue
            best[child] = g_child
            child_state = (end_px[row], end_py[row], end_vx[row], end_vy[row])
            nodes[child] = (key, row, child_state)
            heappush(heap, (g_child + weight * heuristic(*child_state)[0], g_child, child))
    return finish(False, "goal unreachable (open list exhausted)", expansions)


class _KeyEncoder:
    """One integer-valued float per hash cell of an end-state block (4, n) (rows px, py, vx, vy):
    (ix, iy) = floor((p - corner) / pos_res), (ivx, ivy) = rint(v / vel_res) ∈ [-k, k], combined
    as ((ix·ny + iy)·(2k + 1) + ivx)·(2k + 1) + ivy — balanced digits, so distinct cells give
    distinct keys, all exact in float64."""

    def __init__(self, grid: NavGrid, params: NavParams):
        xmin, xmax, ymin, ymax = grid.extent
        inv_p, inv_v = 1.0 / params.pos_res, 1.0 / params.vel_res
        self.corner = np.array([xmin, ymin, 0.0, 0.0])[:, None]
        self.scale = np.array([inv_p, inv_p, inv_v, inv_v])[:, None]
        vel_span = 2 * int(np.ceil(params.v_max * inv_v)) + 3
        ny = int(np.ceil((ymax - ymin) * inv_p)) + 2
        self.radix = np.array([ny * vel_span * vel_span, vel_span * vel_span, vel_span, 1.0])

    def __call__(self, ends: np.ndarray) -> np.ndarray:
        cells = (ends - self.corner) * self.scale
        np.floor(cells[:2], out=cells[:2])
        np.rint(cells[2:], out=cells[2:])
        return np.dot(self.radix, cells)


RESTART_WEIGHTS = (1.0, 1.5, 2.5)  # × params.weight, one search stage each (`_search`)
STAGE_EXPANSIONS_PER_STEP = 10  # stage budget per 8-connected step of the start's route
MIN_STAGE_EXPANSIONS = 2000
ONESHOT_STRETCH = (1.0, 1.25, 1.5, 2.0, 3.0)
ONESHOT_COARSE_STRIDE = 8  # first collision pass: every 8th sample


def analytic_expansion(grid: NavGrid, p, v, pg, vg, T_h: float, params: NavParams):
    """The one-shot cubic of eq. (9) from (p, v) to (pg, vg), or None if infeasible.

    Tries T = T_h (the minimizer of J*, eq. (11), as the search's heuristic computed it) first;
    when that cubic breaks a velocity or acceleration limit — J*'s optimum balances ||a||² against
    ρ and ignores the limits — the duration is stretched by the factors `ONESHOT_STRETCH`
    (J*(T) ≥ J*(T_h), so h stays a lower bound); the first duration whose cubic is within the
    limits and collision-free wins. All durations are checked in one batch: acceleration is linear
    in t (extrema at the ends), velocity quadratic (ends and the vertex t = -β/α); the durations
    within the limits are then checked on their samples (eq. (17) spacing), first on every
    `ONESHOT_COARSE_STRIDE`-th sample — a subset, so a blocked one rejects exactly as the full
    check would, and most rejected cubics cross an obstacle over many samples — then on all
    samples for the durations left. Returns ((p0, v0, a0, jerk, T), cost) with
    cost = J*(T) + ρ_c·c_collision (eqs. (9), (18)).
    """
    if T_h <= 1e-6:
        return None
    durations = T_h * np.array(ONESHOT_STRETCH)[:, None]
    alpha, beta = optimal_polynomial(p, v, pg, vg, durations)  # (K, 2) each
    accel = np.maximum(np.abs(beta), np.abs(beta + alpha * durations)).max(axis=1)
    vertex = np.fmin(np.fmax(np.divide(-beta, alpha, out=np.zeros_like(beta),
                                       where=alpha != 0.0), 0.0), durations)
    speed = np.abs(v + vertex * (beta + 0.5 * alpha * vertex)).max(axis=1)
    within = (accel <= params.a_max + 1e-9) & (speed <= params.v_max + 1e-9)
    cubics = np.concatenate([durations, alpha, beta], axis=1)[within]  # rows T, α, β
    counts = np.array([sample_count(params.v_max, T, grid.resolution)
                       for T in cubics[:, 0].tolist()], dtype=np.intp)
    for stride in (ONESHOT_COARSE_STRIDE, 1):
        if len(cubics):
            free = ~_any_blocked(grid, p, v, cubics, counts, stride)
            cubics, counts = cubics[free], counts[free]
    if not len(cubics):
        return None
    T, alpha, beta, count = float(cubics[0, 0]), cubics[0, 1:3], cubics[0, 3:5], int(counts[0])
    t = np.linspace(0.0, T, count)[:, None]
    positions = p + t * (v + t * (0.5 * beta + t * alpha / 6.0))
    velocities = v + t * (beta + 0.5 * t * alpha)
    effort = float(np.sum(beta**2 * T + alpha * beta * T**2 + alpha**2 * T**3 / 3.0))
    collision = float(np.sum(grid.cost_at(positions) * np.linalg.norm(velocities, axis=1))) \
        * T / (count - 1)
    cost = effort + params.rho * T + params.rho_c * collision
    return (p, v, beta, alpha, T), cost


def _any_blocked(grid: NavGrid, p, v, cubics, counts, stride: int) -> np.ndarray:
    """Per cubic (rows T, α, β) with I + 1 = `counts` samples at i·T/I (as np.linspace: the last
    exactly at T): is any of the samples i = 0, stride, 2·stride, …, I blocked."""
    per = (counts - 2) // stride + 2  # the last sample always, once
    starts = np.cumsum(per) - per
    rows = np.repeat(np.concatenate([cubics, (counts - 1)[:, None]], axis=1), per, axis=0)
    T, alpha, beta, last = rows[:, :1], rows[:, 1:3], rows[:, 3:5], rows[:, 5:]
    i = np.fmin((np.arange(len(rows)) - np.repeat(starts, per))[:, None] * stride, last)
    t = np.where(i == last, T, i * (T / last))
    index = grid.flat_index(p + t * (v + t * (0.5 * beta + t * alpha / 6.0)))
    return np.logical_or.reduceat(grid.blocked_flat[index], starts)


def _reconstruct(nodes, key, prims: PrimitiveSet, last_piece) -> Trajectory:
    """Follow parents from `key` back to the start; primitives then the optional one-shot."""
    pieces = [] if last_piece is None else [last_piece]
    zero = np.zeros(2)
    while True:
        parent, prim, _ = nodes[key]
        if parent is None:
            break
        state = np.array(nodes[parent][2])
        pieces.append((state[:2], state[2:], prims.inputs[prim], zero, prims.tau))
        key = parent
    if not pieces:
        state = np.array(nodes[key][2])
        pieces.append((state[:2], state[2:], zero, zero, 0.0))
    return Trajectory.from_pieces(reversed(pieces))
