"""Heuristic of eqs. (9)–(11): quartic roots, T_h, admissibility and consistency."""

import numpy as np
from scipy.optimize import minimize_scalar

from legplan.nav.heuristic import (GoalHeuristic, depressed_quartic_roots, min_time_cost,
                                   optimal_polynomial)
from legplan.nav.primitives import input_lattice


def quartic_coefficients(pc, vc, pg, vg):
    """Reference (c1, c2, c3) of dJ*/dT · T⁴ = ρT⁴ + c3 T² + c2 T + c1, arrays (..., 2) in."""
    delta = pg - pc
    vs = vc + vg
    dx, dy = delta[..., 0], delta[..., 1]
    c1 = -36.0 * (dx * dx + dy * dy)
    c2 = 24.0 * (vs[..., 0] * dx + vs[..., 1] * dy)
    c3 = -4.0 * ((vs * vs).sum(axis=-1) - (vc * vg).sum(axis=-1))
    return c1, c2, c3


def expanded_cost(T, c1, c2, c3, rho):
    """J*(T) = -c1/(3T³) - c2/(2T²) - c3/T + ρT: eq. (9) expanded with the coefficients above."""
    inv = 1.0 / T
    return ((-c1 / 3.0 * inv - c2 / 2.0) * inv - c3) * inv + rho * T


def eq9_cost(pc, vc, pg, vg, T, rho):
    """J*(T) in the α, β form of eq. (9), independent of the expanded closed form (T scalar or
    1-D array)."""
    T = np.asarray(T, float)[..., None]
    alpha, beta = optimal_polynomial(pc, vc, pg, vg, T)
    return (alpha**2 * T**3 / 3 + alpha * beta * T**2 + beta**2 * T).sum(axis=-1) + rho * T[..., 0]


def test_quartic_roots_match_numpy_roots():
    rng = np.random.default_rng(3)
    p, q, r = rng.normal(size=(3, 800)) * rng.choice([0.1, 1.0, 10.0], size=(3, 800))
    q[:100] = 0.0  # biquadratic case
    for i in range(len(p)):
        reference = np.roots([1.0, 0.0, p[i], q[i], r[i]])
        reference = np.sort(reference[np.abs(reference.imag) < 1e-7].real)
        found = np.array(depressed_quartic_roots(p[i], q[i], r[i]))
        found = np.sort(found[np.isfinite(found)])
        assert found.shape == reference.shape, (p[i], q[i], r[i])
        np.testing.assert_allclose(found, reference, atol=1e-6 * (1 + np.abs(reference).max(initial=0)))


def test_closed_form_cost_equals_eq9():
    rng = np.random.default_rng(4)
    for _ in range(50):
        pc, vc, pg, vg = rng.normal(size=(4, 2))
        c1, c2, c3 = quartic_coefficients(pc, vc, pg, vg)
        T = rng.uniform(0.2, 10.0)
        assert np.isclose(expanded_cost(T, c1, c2, c3, 2.0), eq9_cost(pc, vc, pg, vg, T, 2.0))


def test_T_h_is_the_global_minimizer_of_J():
    rng = np.random.default_rng(5)
    Ts = np.linspace(0.01, 60.0, 60001)
    for _ in range(25):
        pc, pg = rng.uniform(-8, 8, size=(2, 2))
        vc, vg = rng.uniform(-1, 1, size=(2, 2))
        rho = rng.choice([0.1, 1.0, 10.0])
        h, T_h = min_time_cost(pc, vc, pg, vg, rho)
        brute = eq9_cost(pc, vc, pg, vg, Ts[::50], rho)
        k = int(np.argmin(brute))
        fine = minimize_scalar(lambda T: float(eq9_cost(pc, vc, pg, vg, T, rho)),
                               bounds=(Ts[::50][max(k - 1, 0)], Ts[::50][min(k + 1, len(brute) - 1)]),
                               method="bounded", options={"xatol": 1e-10})
        assert h <= fine.fun + 1e-9
        assert np.isclose(h, fine.fun, rtol=1e-7)
        assert np.isclose(T_h, fine.x, rtol=1e-4)
        c1, c2, c3 = quartic_coefficients(pc, vc, pg, vg)
        assert abs(rho * T_h**4 + c3 * T_h**2 + c2 * T_h + c1) < 1e-6 * (1 + abs(c1))


def test_time_bound_minimizes_over_T_at_least_T_lb():
    rng = np.random.default_rng(6)
    for _ in range(25):
        pc, pg = rng.uniform(-8, 8, size=(2, 2))
        vc, vg = rng.uniform(-0.7, 0.7, size=(2, 2))
        h, T_h = min_time_cost(pc, vc, pg, vg, 1.0, v_max=0.75)
        t_lb = np.abs(pg - pc).max() / 0.75
        Ts = np.linspace(t_lb, t_lb + 80.0, 40001)
        brute = eq9_cost(pc, vc, pg, vg, Ts, 1.0).min()
        assert T_h >= t_lb - 1e-12
        assert h <= brute + 1e-9 and h >= brute - 1e-3 * abs(brute)


def random_trajectory_cost(rng, pc, vc, pg, vg, rho, steps=5, tau=0.4):
    """Cost ∫||a||² + ρT of a trajectory reaching the goal state exactly: random constant inputs
    then the eq. (9) cubic of a random duration. Returns (cost, max per-axis speed)."""
    p, v, cost, speeds = pc.copy(), vc.copy(), 0.0, [np.abs(vc).max()]
    for _ in range(steps):
        u = rng.uniform(-1, 1, 2)
        p, v = p + v * tau + 0.5 * u * tau**2, v + u * tau
        cost += (u @ u + rho) * tau
        speeds.append(np.abs(v).max())
    T = rng.uniform(0.5, 20.0)
    cost += eq9_cost(p, v, pg, vg, T, rho)
    alpha, beta = optimal_polynomial(p, v, pg, vg, T)
    t = np.linspace(0, T, 2001)[:, None]
    speeds.append(np.abs(v + beta * t + 0.5 * alpha * t**2).max())
    return cost, max(speeds)


def test_heuristic_never_exceeds_the_cost_of_a_trajectory_to_the_goal():
    rng = np.random.default_rng(7)
    for _ in range(300):
        pc, pg = rng.uniform(-5, 5, size=(2, 2))
        vc, vg = rng.uniform(-0.7, 0.7, size=(2, 2))
        rho = rng.choice([0.5, 1.0, 5.0])
        cost, speed = random_trajectory_cost(rng, pc, vc, pg, vg, rho)
        assert min_time_cost(pc, vc, pg, vg, rho)[0] <= cost + 1e-9
        # With the time bound, admissible for trajectories whose per-axis speed stays ≤ v_max.
        assert min_time_cost(pc, vc, pg, vg, rho, v_max=speed)[0] <= cost + 1e-9


def independent_heuristic(pc, vc, pg, vg, rho, v_max):
    """min over T ≥ max_d |Δ_d| / v_max of J*(T) in the α, β form of eq. (9), by a dense grid of
    durations refined with scipy's bounded scalar minimizer (no code shared with GoalHeuristic)."""
    t_lb = max(np.abs(pg - pc).max() / v_max, 1e-9)
    Ts = np.linspace(t_lb, t_lb + 60.0, 6001)
    costs = eq9_cost(pc, vc, pg, vg, Ts, rho)
    k = int(np.argmin(costs))
    fine = minimize_scalar(lambda T: float(eq9_cost(pc, vc, pg, vg, T, rho)),
                           bounds=(Ts[max(k - 1, 0)], Ts[min(k + 1, len(Ts) - 1)]), method="bounded",
                           options={"xatol": 1e-10})
    return min(fine.fun, costs[k])


def test_goal_heuristic_matches_an_independent_minimization_and_is_consistent():
    """The search's scalar h of the children of a node equals an independent minimization of
    eq. (9) over the admissible durations, and is consistent along every feasible primitive."""
    rng = np.random.default_rng(8)
    inputs = input_lattice(2, 1.0)
    tau, rho = 0.4, 1.0
    for _ in range(12):
        p0, pg = rng.uniform(-6, 6, size=(2, 2))
        v0, vg = rng.uniform(-0.5, 0.5, size=(2, 2))
        heuristic = GoalHeuristic(pg, vg, rho, 0.75)
        p_children = p0 + v0 * tau + 0.5 * inputs * tau**2
        v_children = v0 + inputs * tau
        h_children = np.array([heuristic(*p, *v)[0] for p, v in zip(p_children, v_children)])
        h_direct = [independent_heuristic(p, v, pg, vg, rho, 0.75) for p, v in zip(p_children, v_children)]
        np.testing.assert_allclose(h_children, h_direct, rtol=1e-7)
        feasible = np.abs(v_children).max(axis=1) <= 0.75
        h_parent = heuristic(*p0, *v0)[0]
        edge = ((inputs**2).sum(axis=1) + rho) * tau
        assert np.all(h_parent <= edge[feasible] + h_children[feasible] + 1e-9)
