"""The kinodynamic A* heuristic: the linear-quadratic minimum-time cost, eqs. (9)–(11).

For a double integrator moving from (p_c, v_c) to (p_g, v_g) in time T, the minimum of
∫||a||² dt + ρT over cubic position profiles (Pontryagin, eq. (9)) expands, with Δ = p_g - p_c, to

    J*(T) = 12|Δ|²/T³ - 12 (v_c + v_g)·Δ / T² + 4 (|v_c|² + v_c·v_g + |v_g|²) / T + ρT.

dJ*/dT = 0 multiplied by T⁴ is the depressed quartic ρT⁴ + c3 T² + c2 T + c1 = 0 with
c1 = -36|Δ|², c2 = 24 (v_c + v_g)·Δ, c3 = -4 (|v_c|² + v_c·v_g + |v_g|²). Its real roots come from
Ferrari's method in closed form (vectorized over many states; `numpy.roots` is ~100× slower per
state); h = J*(T_h) at the positive root with the least cost (eq. (11)).

Admissibility. Any trajectory reaching the goal state in time T (the search's chain of constant
inputs plus the final one-shot cubic) costs ∫||a||² + ρT ≥ J*(T) ≥ min_T J*(T): h is a lower bound
of the cost-to-go and, by the same argument applied to "one primitive then the optimal rest",
consistent. The soft collision cost (eq. (19)) only adds non-negative terms, so it keeps both.
With `time_bound=True` (default) the minimum is taken over T ≥ T_lb = max_d |Δ_d| / v_max, the
shortest time any trajectory obeying the per-axis speed bound needs; this stays a lower bound
(every feasible trajectory has T ≥ T_lb) and is far tighter when ρ is large. `weight` > 1 in the
search (f = g + w·h) trades the optimality bound w for fewer expansions (weighted A*).
"""

from __future__ import annotations

import numpy as np

def quartic_coefficients(pc, vc, pg, vg):
    """(c1, c2, c3) of dJ*/dT · T⁴ = ρT⁴ + c3 T² + c2 T + c1, per state (arrays (..., 2) in)."""
    delta = pg - pc
    vs = vc + vg
    dx, dy = delta[..., 0], delta[..., 1]
    c1 = -36.0 * (dx * dx + dy * dy)
    c2 = 24.0 * (vs[..., 0] * dx + vs[..., 1] * dy)
    c3 = -4.0 * ((vs * vs).sum(axis=-1) - (vc * vg).sum(axis=-1))
    return c1, c2, c3


def cost_at(T, c1, c2, c3, rho):
    """J*(T) = -c1/(3T³) - c2/(2T²) - c3/T + ρT (eq. (9) expanded)."""
    inv = 1.0 / T
    return ((-c1 / 3.0 * inv - c2 / 2.0) * inv - c3) * inv + rho * T


def depressed_quartic_roots(p, q, r):
    """Real roots of x⁴ + p x² + q x + r = 0 by Ferrari's method: (4, ...) with NaN for complex.

    The resolvent cubic y³ + p y² + (p²/4 - r) y - q²/8 = 0 has a real root y ≥ 0 (its value at 0
    is -q²/8 ≤ 0); its largest real root comes from Cardano's formula (one real root) or the
    trigonometric form (three real roots). With s = √(2y) and o = q/(2s) = ±√(y² + p y + p²/4 - r)
    (sign of q; either sign when q = 0, the biquadratic case) the quartic splits into
    x² ∓ s x + p/2 + y ± o = 0. Written with few, cheap ufuncs (no np.where on the roots, no
    np.clip): it runs once per expansion. Call under `np.errstate(invalid="ignore")`.
    """
    pp = p * p
    c = 0.25 * pp - r
    P = c - pp * (1.0 / 3.0)
    Q = (pp * (2.0 / 27.0) - c * (1.0 / 3.0)) * p - 0.125 * q * q
    disc = 0.25 * Q * Q + P * P * P * (1.0 / 27.0)
    sq = np.sqrt(disc)  # NaN where three real roots
    cardano = np.cbrt(sq - 0.5 * Q) - np.cbrt(sq + 0.5 * Q)
    m = np.sqrt(P * (-1.0 / 3.0))  # NaN where P > 0 (then disc > 0)
    cosine = np.fmin(np.fmax(1.5 * Q / (P * m), -1.0), 1.0)
    trig = 2.0 * m * np.cos(np.arccos(cosine) * (1.0 / 3.0))
    z = np.where(disc > 0.0, cardano, trig)
    y = np.fmax(z - p * (1.0 / 3.0), 0.0)
    offset = np.copysign(np.sqrt(np.fmax(y * (y + p) + c, 0.0)), q)
    half = np.sqrt(0.5 * y)  # s / 2
    base = half * half - 0.5 * p - y
    root_plus = np.sqrt(base - offset)  # x² - s x + (p/2 + y + o) = 0
    root_minus = np.sqrt(base + offset)  # x² + s x + (p/2 + y - o) = 0
    roots = np.empty((4,) + np.shape(half))
    roots[0] = half + root_plus
    roots[1] = half - root_plus
    roots[2] = root_minus - half
    roots[3] = -half - root_minus
    return roots


def _candidate_costs(p, q, r, t_lb):
    """Candidate durations (4, ...) — roots of T⁴ + p T² + q T + r (the quartic divided by ρ)
    raised to at least t_lb (> 0), so complex or too-short roots become t_lb itself — and
    J*(T) / ρ at each (eq. (9))."""
    T = np.fmax(depressed_quartic_roots(p, q, r), t_lb)
    inv = 1.0 / T
    return T, ((r * (-1.0 / 3.0) * inv - 0.5 * q) * inv - p) * inv + T


def min_time_cost(pc, vc, pg, vg, rho: float, v_max: float | None = None):
    """h = min_T J*(T) and its T_h for each state (eqs. (9)–(11)); arrays (..., 2) → (...), (...).

    Candidates are the positive real roots of the quartic and, when `v_max` is given, the lower
    time bound T_lb = max_d |Δ_d| / v_max (roots below T_lb are discarded). At the goal itself
    (Δ = 0, v_c = v_g = 0) h → 0 as T → 0; the search floor is T = 1e-9 s.
    """
    pc, vc, pg, vg = np.broadcast_arrays(*(np.asarray(a, float) for a in (pc, vc, pg, vg)))
    c1, c2, c3 = quartic_coefficients(pc, vc, pg, vg)
    t_lb = _MIN_T if v_max is None else np.maximum(np.abs(pg - pc).max(axis=-1) / v_max, _MIN_T)
    with np.errstate(invalid="ignore", divide="ignore"):
        T, costs = _candidate_costs(c3 / rho, c2 / rho, c1 / rho, t_lb)
    best = costs.argmin(axis=0)[None]
    return (rho * np.take_along_axis(costs, best, axis=0)[0],
            np.take_along_axis(T, best, axis=0)[0])


_MIN_T = 1e-9


class ChildHeuristic:
    """h for all children of one node at once, for a fixed goal and primitive set (hot path).

    A child's Δ = D - (τ²/2) u and velocities v0 + τu are affine in the input u, so c1, c2, c3 and
    Δ are one small matrix product [1, u_x, u_y, |u|²] · W(node) (W from the node's scalars, with
    1/ρ folded in); then the vectorized quartic roots and the candidate costs. Call under
    `np.errstate(invalid="ignore", divide="ignore")`.
    """

    def __init__(self, inputs, tau, pg, vg, rho, v_max: float | None):
        self.features = np.stack([np.ones(len(inputs)), inputs[:, 0], inputs[:, 1],
                                  (inputs**2).sum(axis=1)])  # (4, M)
        self.tau, self.rho = float(tau), float(rho)
        self.pg, self.vg = np.asarray(pg, float), np.asarray(vg, float)
        self.inv_v = None if v_max is None else 1.0 / v_max

    def __call__(self, p0: np.ndarray, v0: np.ndarray) -> np.ndarray:
        tau, h2 = self.tau, 0.5 * self.tau**2
        dx, dy = (self.pg - p0 - v0 * tau).tolist()
        sx, sy = (v0 + self.vg).tolist()
        v0x, v0y = v0.tolist()
        gx, gy = self.vg.tolist()
        weights = np.array([
            [-36.0 * (dx * dx + dy * dy), 72.0 * h2 * dx, 72.0 * h2 * dy, -36.0 * h2 * h2],
            [24.0 * (sx * dx + sy * dy), 24.0 * (tau * dx - h2 * sx), 24.0 * (tau * dy - h2 * sy),
             -24.0 * tau * h2],
            [-4.0 * (v0x * v0x + v0y * v0y + v0x * gx + v0y * gy + gx * gx + gy * gy),
             -4.0 * tau * (2.0 * v0x + gx), -4.0 * tau * (2.0 * v0y + gy), -4.0 * tau * tau],
            [dx, -h2, 0.0, 0.0],
            [dy, 0.0, -h2, 0.0]])
        weights[:3] *= 1.0 / self.rho
        r, q, p, delta_x, delta_y = weights @ self.features
        if self.inv_v is None:
            t_lb = _MIN_T
        else:
            t_lb = np.maximum(np.maximum(np.abs(delta_x), np.abs(delta_y)) * self.inv_v, _MIN_T)
        return self.rho * _candidate_costs(p, q, r, t_lb)[1].min(axis=0)


def optimal_polynomial(pc, vc, pg, vg, T: float):
    """Coefficients (α, β) per axis of the optimal cubic of eq. (9) for duration T: jerk α, a(0)=β."""
    delta = pg - pc - vc * T
    dv = vg - vc
    alpha = (-12.0 * delta + 6.0 * T * dv) / T**3
    beta = (6.0 * T * delta - 2.0 * T * T * dv) / T**3
    return alpha, beta
