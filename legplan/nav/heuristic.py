"""The kinodynamic A* heuristic: the linear-quadratic minimum-time cost, eqs. (9)–(11).

For a double integrator moving from (p_c, v_c) to (p_g, v_g) in time T, the minimum of
∫||a||² dt + ρT over cubic position profiles (Pontryagin, eq. (9)) expands, with Δ = p_g - p_c, to

    J*(T) = 12|Δ|²/T³ - 12 (v_c + v_g)·Δ / T² + 4 (|v_c|² + v_c·v_g + |v_g|²) / T + ρT.

dJ*/dT = 0 multiplied by T⁴ is the depressed quartic ρT⁴ + c3 T² + c2 T + c1 = 0 with
c1 = -36|Δ|², c2 = 24 (v_c + v_g)·Δ, c3 = -4 (|v_c|² + v_c·v_g + |v_g|²). Its real roots come from
Ferrari's method in closed form; h = J*(T_h) at the positive root with the least cost (eq. (11)).
The search evaluates h one state at a time in plain Python floats (`GoalHeuristic`): it needs h
only for the children that enter the open list (about 5 of 25 per expansion in steady state), and
a scalar evaluation (1–2 µs) costs far less than the ~30 µs fixed overhead of the ~60 numpy ufunc
calls a vectorized Ferrari needs per batch. With the time bound below, far from the goal the
bound itself is usually the minimizer, which a sign test on the quartic detects before Ferrari.

Admissibility. Any trajectory reaching the goal state in time T (the search's chain of constant
inputs plus the final one-shot cubic) costs ∫||a||² + ρT ≥ J*(T) ≥ min_T J*(T): h is a lower bound
of the cost-to-go and, by the same argument applied to "one primitive then the optimal rest",
consistent. The soft collision cost (eq. (19)) only adds non-negative terms, so it keeps both.
With `time_bound=True` (default) the minimum is taken over T ≥ T_lb = max_d |Δ_d| / v_max, the
shortest time any trajectory obeying the per-axis speed bound needs; this stays a lower bound
(every feasible trajectory has T ≥ T_lb) and is far tighter when ρ is large. `weight` > 1 in the
search (f = g + w·h) trades the optimality bound w for fewer expansions (weighted A*).
`GeodesicTimeBound` (`geodesic_bound=True`, default) raises T_lb towards the time the robot needs
along the shortest route around the obstacles (see there); it keeps h admissible and consistent.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np

from legplan.nav.collision import NavGrid

_MIN_T = 1e-9


def depressed_quartic_roots(p: float, q: float, r: float) -> tuple[float, float, float, float]:
    """The four roots of x⁴ + p x² + q x + r = 0 by Ferrari's method, NaN where complex (floats).

    The resolvent cubic y³ + p y² + (p²/4 - r) y - q²/8 = 0 has a real root y ≥ 0 (its value at 0
    is -q²/8 ≤ 0). With y = z - p/3 it is z³ + 3A z + 2B = 0, A = -(p²/36 + r/3),
    B = p (r/6 - p²/216) - q²/16; its largest real root is Cardano's z = ∛(√D - B) - ∛(√D + B)
    when D = B² + A³ > 0 (one real root), else the trigonometric 2√-A cos(acos(B / (A√-A)) / 3).
    With s = √(2y) and o = ±√(y² + p y + p²/4 - r) (sign of q; either when q = 0) the quartic
    splits into x² ∓ s x + p/2 + y ± o = 0, whose discriminants are s²/4 - p/2 - y ∓ o =
    -(y + p)/2 ∓ o. Scalar on purpose: the search evaluates one state at a time (module doc).
    """
    pp = p * p
    A = pp * (-1.0 / 36.0) - r * (1.0 / 3.0)
    B = p * (r * (1.0 / 6.0) - pp * (1.0 / 216.0)) - q * q * (1.0 / 16.0)
    disc = B * B + A * A * A
    if disc > 0.0:
        sq = math.sqrt(disc)
        z = math.cbrt(sq - B) - math.cbrt(sq + B)
    elif A < 0.0:
        m = math.sqrt(-A)
        z = 2.0 * m * math.cos(math.acos(min(max(B / (A * m), -1.0), 1.0)) * (1.0 / 3.0))
    else:  # A = B = 0: the triple root z = 0
        z = 0.0
    y = max(z - p * (1.0 / 3.0), 0.0)
    offset = math.sqrt(max(y * (y + p) + 0.25 * pp - r, 0.0))
    if q < 0.0:
        offset = -offset
    half = math.sqrt(0.5 * y)  # s / 2
    base = -0.5 * (y + p)
    # x² - s x + (p/2 + y + o) = 0 and x² + s x + (p/2 + y - o) = 0
    plus = math.sqrt(base - offset) if base >= offset else math.nan
    minus = math.sqrt(base + offset) if base >= -offset else math.nan
    return half + plus, half - plus, minus - half, -half - minus


def min_time_cost(pc, vc, pg, vg, rho: float, v_max: float | None = None):
    """h = min_T J*(T) and its T_h for each state (eqs. (9)–(11)); arrays (..., 2) → (...), (...).

    Candidates are the positive real roots of the quartic and, when `v_max` is given, the lower
    time bound T_lb = max_d |Δ_d| / v_max (roots below T_lb are discarded). At the goal itself
    (Δ = 0, v_c = v_g = 0) h → 0 as T → 0; the search floor is T = 1e-9 s. Evaluates
    `GoalHeuristic` state by state.
    """
    pc, vc, pg, vg = np.broadcast_arrays(*(np.asarray(a, float) for a in (pc, vc, pg, vg)))
    states = np.concatenate([pc, vc, pg, vg], axis=-1).reshape(-1, 8).tolist()
    minima = [GoalHeuristic(s[4:6], s[6:8], rho, v_max)(*s[:4]) for s in states]
    cost, T = np.array(minima, float).reshape(-1, 2).T
    return cost.reshape(pc.shape[:-1]), T.reshape(pc.shape[:-1])


class GoalHeuristic:
    """(h, T_h) = min_T J*(T) and its minimizer to a fixed goal for one state given as floats (the
    search's hot path): eqs. (9)–(11) with c1, c2, c3 of the module doc divided by ρ."""

    def __init__(self, pg, vg, rho: float, v_max: float | None,
                 time_floor: Callable[[float, float, float], float] | None = None):
        self.gx, self.gy = (float(x) for x in pg)
        self.gvx, self.gvy = (float(x) for x in vg)
        self.goal_speed2 = self.gvx * self.gvx + self.gvy * self.gvy
        self.rho, self.inv_rho = float(rho), 1.0 / rho
        self.inv_v = None if v_max is None else 1.0 / v_max
        self.time_floor = time_floor  # (px, py, straight-line bound) → a tighter time bound

    def __call__(self, px: float, py: float, vx: float, vy: float) -> tuple[float, float]:
        dx, dy = self.gx - px, self.gy - py
        gvx, gvy, inv_rho = self.gvx, self.gvy, self.inv_rho
        r = -36.0 * (dx * dx + dy * dy) * inv_rho
        q = 24.0 * ((vx + gvx) * dx + (vy + gvy) * dy) * inv_rho
        p = -4.0 * (vx * vx + vy * vy + vx * gvx + vy * gvy + self.goal_speed2) * inv_rho
        t_lb = _MIN_T if self.inv_v is None else max(max(abs(dx), abs(dy)) * self.inv_v, _MIN_T)
        if self.time_floor is not None:
            t_lb = max(self.time_floor(px, py, t_lb), _MIN_T)
        # Candidates: t_lb and the real roots of g(T) = T⁴ + p T² + q T + r above it (eq. (11)),
        # with J*(T)/ρ = ((-r/3 /T - q/2)/T - p)/T + T and dJ*/dT ∝ g.
        inv = 1.0 / t_lb
        best = ((r * (-1.0 / 3.0) * inv - 0.5 * q) * inv - p) * inv + t_lb
        best_T = t_lb
        tt = t_lb * t_lb
        if 6.0 * tt >= -p and (4.0 * tt + 2.0 * p) * t_lb + q >= 0.0 and \
                (tt + p) * tt + q * t_lb + r >= 0.0:
            # g'' = 12T² + 2p, g' and g are ≥ 0 at t_lb, so g ≥ 0 on [t_lb, ∞): J* does not
            # decrease there and t_lb is the minimizer (no root above it can do better). This is
            # the usual case with the time bound far from the goal; it skips Ferrari.
            return self.rho * best, best_T
        for T in depressed_quartic_roots(p, q, r):
            if T > t_lb:  # False for NaN
                inv = 1.0 / T
                cost = ((r * (-1.0 / 3.0) * inv - 0.5 * q) * inv - p) * inv + T
                if cost < best:
                    best, best_T = cost, T
        return self.rho * best, best_T


class GeodesicTimeBound:
    """A lower bound of the time from position p to the goal that accounts for obstacles
    (`geodesic_bound`, default on): T_lb(p) = T_s + κ·max(T_g(p) - T_s, 0), where T_s = max_d |Δ_d|
    / v_max is the straight-line bound of the module doc and T_g(p) = max(D(p) - R, 0) / v_max
    the time along the shortest route.

    D(p) = R × the 8-connected step count from the goal's cell to p's cell through passable cells
    (`NavGrid.step_distance`, R the cell size): one breadth-first search per goal. Unit steps,
    diagonals included, measure length in the Chebyshev metric, the one the per-axis speed bound
    |v_d| ≤ v_max of eq. (2) limits (a diagonal runs at √2·v_max, so a Euclidean or octile
    distance / v_max would overestimate the time and break admissibility).

    Admissible: trajectories stay in passable cells, so over a duration T with Chebyshev length
    L ≤ v_max T the cells they visit link p's cell to the goal's in ≤ L/R + 1 steps (split the path
    into pieces shorter than R per axis): D(p) - R ≤ L, T ≥ T_g(p); also T ≥ T_s, and a convex
    combination of the two is ≤ T. Consistent: along one primitive T_s drops by ≤ τ, D by at most
    (⌊v_max τ / R⌋ + 1) R, so with κ = v_max τ / ((⌊v_max τ / R⌋ + 1) R) ≤ 1 the bound
    (1 - κ) T_s + κ T_g drops by ≤ τ; so does the max with T_s, which keeps h = min over T ≥ T_lb of
    J*(T) consistent (eqs. (9)–(11), module doc).

    Why not κ·T_g alone (the earlier form): at R = 0.2 m, v_max τ = 0.3 m, κ = 0.75, and
    max(T_s, κ T_g) is T_s along whole streets that lead across the goal's dominant axis, where
    T_s is flat (moving along the other axis does not shorten max_d |Δ_d|): h had plateaus there
    and weighted A* flooded them (`BENCHMARKS.md`, nav_scale). The combination above falls with
    slope ≥ κ along every route. inf where the goal is unreachable.
    """

    def __init__(self, grid: NavGrid, goal_xy, v_max: float, tau: float):
        R, reach = grid.resolution, v_max * tau
        self.kappa = reach / ((math.floor(reach / R) + 1) * R)
        self.route_time = (R / v_max) * np.maximum(grid.step_distance(goal_xy) - 1.0, 0.0)
        self.x0, self.y0 = grid.origin
        self.resolution, self.v_max = R, v_max

    def __call__(self, px: float, py: float, straight: float) -> float:
        """T_lb at the cell holding (px, py) (`Grid2D.cell_of`) given T_s = `straight`."""
        excess = self.route_time_at(px, py) - straight
        return straight + self.kappa * excess if excess > 0.0 else straight

    def route_time_at(self, px: float, py: float) -> float:
        """T_g at the cell holding (px, py) (`Grid2D.cell_of`); inf off the goal's routes."""
        ix = math.floor((px - self.x0) / self.resolution + 0.5)
        iy = math.floor((py - self.y0) / self.resolution + 0.5)
        return float(self.route_time[iy, ix])

    def route_steps(self, px: float, py: float) -> float:
        """D(p)/R - 1 ≥ the 8-connected steps of the route from (px, py) to the goal, minus one."""
        return self.route_time_at(px, py) * self.v_max / self.resolution


def optimal_polynomial(pc, vc, pg, vg, T: float):
    """Coefficients (α, β) per axis of the optimal cubic of eq. (9) for duration T: jerk α, a(0)=β.

    With δ = p_g - p_c - v_c T and Δv = v_g - v_c, eq. (9) reads α = 6 Δv/T² - 12 δ/T³,
    β = 6 δ/T² - 2 Δv/T (evaluated with 1/T, no powers: the one-shot calls it per expansion).
    """
    inv = 1.0 / T
    scaled_delta = (pg - pc - vc * T) * (inv * inv)  # δ/T²
    scaled_dv = (vg - vc) * inv  # Δv/T
    alpha = (6.0 * scaled_dv - 12.0 * scaled_delta) * inv
    beta = 6.0 * scaled_delta - 2.0 * scaled_dv
    return alpha, beta
