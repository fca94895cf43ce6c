"""LM with hinged rows: the model step, convergence, and the agreement with plain LM on smooth rows."""

import numpy as np
import pytest

from legplan.solve import FunctionBlock, LMParams, Problem, Status, VariableBlock, solve_lm
from legplan.solve.blocks import LinearBlock
from legplan.solve.hinged import HingedParams, hinged_norm, solve_hinged_lm


class _Hinged(LinearBlock):
    hinged = True


def test_hinged_norm():
    v = np.array([1.0, -2.0, 3.0])
    assert hinged_norm(v, np.array([False, True, True])) == pytest.approx(np.hypot(1.0, 3.0))


def test_root_of_equalities_and_hinges_found_in_few_steps():
    # x0 + x1 = 1 (equality), x0 ≤ 0.2 and x1 ≤ 0.9 (hinged): the root set is x0 ∈ [0.1, 0.2]
    p = Problem([VariableBlock("x", [2.0, 2.0])])
    p.add_residual(LinearBlock(("x",), [np.array([[1.0, 1.0]])], 1.0))
    p.add_residual(_Hinged(("x",), [np.eye(2)], np.array([0.2, 0.9])))
    assert p.hinge_mask().tolist() == [False, True, True]
    r = solve_hinged_lm(p, HingedParams(tolerance=1e-12))
    assert r.status is Status.CONVERGED and r.iterations <= 3
    x = r.values["x"]
    assert x.sum() == pytest.approx(1.0) and x[0] <= 0.2 + 1e-9 and x[1] <= 0.9 + 1e-9


def test_smooth_problem_matches_plain_lm():
    def rosen(x):
        return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]]), [np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])]
    runs = []
    for solver in ("hinged", "lm"):
        p = Problem([VariableBlock("x", [-1.2, 1.0])])
        p.add_residual(FunctionBlock(("x",), 2, rosen))
        r = (solve_hinged_lm(p, HingedParams(tolerance=1e-10, max_iterations=200)) if solver == "hinged"
             else solve_lm(p, LMParams(tolerance=1e-10, max_iterations=200)))
        assert r.success, r.reason
        runs.append(r.values["x"])
    assert runs[0] == pytest.approx(runs[1], abs=1e-8) and runs[0] == pytest.approx([1.0, 1.0], abs=1e-8)


def test_row_tolerance_stops_once_every_row_is_within_its_own():
    """Rows in different units: a coarse row tolerance is met before the norm test of the finest one
    (which must assume the worst row) would stop; each row is within its tolerance at the result."""
    def rows(x):
        return (np.array([x[0] ** 3 - 8.0, 1e-3 * (x[1] ** 3 - 1.0)]),
                [np.array([[3 * x[0] ** 2, 0.0], [0.0, 3e-3 * x[1] ** 2]])])
    tolerance = np.array([1e-1, 1e-6])
    runs = {}
    for name, kwargs in (("rows", {"row_tolerance": tolerance}), ("norm", {})):
        p = Problem([VariableBlock("x", [4.0, 1.5])])
        p.add_residual(FunctionBlock(("x",), 2, rows))
        runs[name] = solve_hinged_lm(p, HingedParams(tolerance=0.0 if kwargs else tolerance.min()), **kwargs)
        assert runs[name].status is Status.CONVERGED, runs[name].reason
        h = rows(runs[name].values["x"])[0]
        assert np.all(np.abs(h) <= tolerance)
    assert runs["rows"].stopped_by == "row_tolerance" and runs["norm"].stopped_by == "tolerance"
    assert runs["rows"].iterations < runs["norm"].iterations


def test_function_tolerance_stops_at_a_nonzero_minimum():
    p = Problem([VariableBlock("x", [5.0])])
    p.add_residual(LinearBlock(("x",), [np.array([[1.0], [1.0]])], np.array([0.0, 2.0])))  # min at x = 1, ‖h‖ = √2
    r = solve_hinged_lm(p, HingedParams(lambda_init=10.0, function_tolerance=1e-8, tolerance=0.0))
    assert r.status is Status.CONVERGED and r.stopped_by == "function_tolerance"
    assert r.values["x"] == pytest.approx([1.0], abs=1e-3)


def _quadratic_rows(x):
    """r = [x0² + x1 − 1, x0·x1, 2 − x1]: second directional derivative along d is [2d0², 2d0d1, 0]."""
    return (np.array([x[0] ** 2 + x[1] - 1.0, x[0] * x[1], 2.0 - x[1]]),
            [np.array([[2 * x[0], 1.0], [x[1], x[0]], [0.0, -1.0]])])


def test_geodesic_acceleration_solves_the_damped_system_with_the_exact_curvature():
    from legplan.solve.hinged import _HingeModel
    from legplan.solve.linsolve import make_solver
    from legplan.solve.lm import Timings

    x = np.array([0.7, -0.4])
    v, (J,) = _quadratic_rows(x)
    import scipy.sparse as sp
    J = sp.csr_matrix(J)
    model = _HingeModel(J, v, np.zeros(3, bool), 2)
    solver = make_solver("cholmod")
    lam = 0.3
    d_scaled = model.step(solver, lam, 10, Timings())
    d = model.scale * d_scaled
    h = 0.1  # the residuals are quadratic: the finite difference of the method is exact
    difference = (_quadratic_rows(x + h * d)[0] - v) / h - J @ d
    a = model.acceleration(solver, difference, h)
    Js = J.toarray() * model.scale
    r_vv = np.array([2 * d[0] ** 2, 2 * d[0] * d[1], 0.0])
    expected = -np.linalg.solve(Js.T @ Js + lam * np.eye(2), Js.T @ r_vv)
    assert a == pytest.approx(expected, rel=1e-9, abs=1e-12)


def test_geodesic_acceleration_takes_fewer_steps_on_a_curved_valley():
    # Rosenbrock's valley is the textbook case of parameter-effects curvature (Transtrum & Sethna)
    def rosen(x):
        return np.array([10 * (x[1] - x[0] ** 2), 1 - x[0]]), [np.array([[-20 * x[0], 10.0], [-1.0, 0.0]])]
    runs = {}
    for alpha in (0.0, 0.75):
        p = Problem([VariableBlock("x", [-1.2, 1.0])])
        p.add_residual(FunctionBlock(("x",), 2, rosen))
        r = solve_hinged_lm(p, HingedParams(tolerance=1e-10, max_iterations=200, geodesic_acceleration=alpha))
        assert r.success and r.values["x"] == pytest.approx([1.0, 1.0], abs=1e-8)
        runs[alpha] = r.iterations
    assert runs[0.75] < runs[0.0]


def _model_value(J, v, hinged, lam, d):
    r = v + J @ d
    return float(np.sum(np.where(hinged, np.maximum(r, 0.0), r) ** 2) + lam * d @ d)


@pytest.mark.parametrize("seed", range(40))
def test_model_line_search_finds_the_minimum_along_the_direction(seed):
    from legplan.solve.hinged import _model_line_search

    rng = np.random.default_rng(seed)
    m, n = rng.integers(3, 40), rng.integers(2, 12)
    a, b = rng.normal(size=m), rng.normal(size=m) * rng.uniform(0.1, 5.0)
    hinged = rng.random(m) < 0.6
    d, p, lam = rng.normal(size=n), rng.normal(size=n), rng.uniform(0.0, 1.0)

    def phi(t):
        r = a + t * b
        return np.sum(np.where(hinged, np.maximum(r, 0.0), r) ** 2) + lam * np.sum((d + t * p) ** 2)

    grid = np.linspace(0.0, 1.0, 20001)
    t = _model_line_search(a, b, hinged, lam, d, p)
    assert 0.0 <= t <= 1.0
    assert phi(t) <= min(phi(s) for s in grid) + 1e-12


@pytest.mark.parametrize("seed", range(20))
def test_model_step_never_raises_the_model_and_reaches_its_minimum(seed):
    """Many hinges crossing at once (an underdetermined system, small damping: the centroidal
    projection's case) make the plain active-set iteration cycle; with the exact line search each pass
    lowers the convex model, so even one pass is a descent step and enough passes reach its minimum."""
    import scipy.optimize
    import scipy.sparse as sp

    from legplan.solve.hinged import _HingeModel
    from legplan.solve.linsolve import make_solver
    from legplan.solve.lm import Timings

    rng = np.random.default_rng(seed)
    m, n = 60, 40
    J = sp.csr_matrix(rng.normal(size=(m, n)) * (rng.random((m, n)) < 0.3))
    v = rng.normal(size=m) * 3.0
    hinged = rng.random(m) < 0.7
    lam = 1e-4
    model = _HingeModel(J, v, hinged, n)
    Js = J.toarray() * model.scale
    start = _model_value(Js, v, hinged, lam, np.zeros(n))
    for passes in (1, 2, 3):
        step = model.step(make_solver("cholmod"), lam, passes, Timings())
        assert _model_value(Js, v, hinged, lam, step) <= start + 1e-12
    step = model.step(make_solver("cholmod"), lam, 200, Timings())

    def grad(d):
        r = v + Js @ d
        return 2 * Js.T @ np.where(hinged, np.maximum(r, 0.0), r) + 2 * lam * d
    best = scipy.optimize.minimize(lambda d: _model_value(Js, v, hinged, lam, d), np.zeros(n), jac=grad,
                                   method="L-BFGS-B", options={"maxiter": 20000, "ftol": 1e-15, "gtol": 1e-12})
    assert _model_value(Js, v, hinged, lam, step) <= best.fun + 1e-6 * max(1.0, abs(best.fun))


def test_factorizing_on_the_entries_ever_nonzero_gives_the_answer_of_the_whole_pattern(monkeypatch):
    """`solve_hinged_lm` factorizes `Problem.nonzero_jacobian` (explicit zeros left out, the pattern
    growing as entries turn nonzero); with the whole structural pattern instead, the same steps:
    equal iterations, answers equal to round-off (the fill-reducing order differs)."""
    import scipy.sparse as sp

    rng = np.random.default_rng(5)
    n, m = 40, 60
    A = sp.random(m, n, density=0.2, random_state=rng, format="csr")  # the declared pattern
    rows, cols = np.repeat(np.arange(m), np.diff(A.indptr)), A.indices
    kind = rng.integers(0, 3, A.nnz)  # 0: c·x_j², 1: b·x_j, 2: a structural zero (never nonzero)
    coef = rng.normal(size=A.nnz)
    targets = rng.normal(size=m)

    def fn(x):  # x starts at zero on even columns: their quadratic entries turn nonzero later
        terms = np.where(kind == 0, coef * x[cols] ** 2, np.where(kind == 1, coef * x[cols], 0.0))
        values = np.where(kind == 0, 2.0 * coef * x[cols], np.where(kind == 1, coef, 0.0))
        r = np.bincount(rows, weights=terms, minlength=m) - targets
        return r, [sp.csr_matrix((values, A.indices, A.indptr), shape=A.shape)]

    class Hinged(FunctionBlock):
        hinged = np.arange(m) % 3 == 0

    def solve():
        p = Problem([VariableBlock("x", np.where(np.arange(n) % 2 == 0, 0.0, 0.5))])
        p.add_residual(Hinged(("x",), m, fn))
        start = p.nonzero_jacobian(p.layout.initial())[1].nnz
        return p, start, solve_hinged_lm(p, HingedParams(max_iterations=40, tolerance=1e-12))

    problem, start, reduced = solve()
    _, J = problem.jacobian(problem.layout.initial())
    assert problem.nonzero_version >= 2  # the pattern grew during the solve
    assert start < problem.nonzero_jacobian(reduced.theta)[1].nnz < J.nnz
    monkeypatch.setattr(Problem, "nonzero_jacobian", lambda self, theta: (lambda hj: (hj[0], sp.csr_matrix(hj[1])))(
        self.jacobian(theta)))
    _, _, whole = solve()
    assert reduced.iterations == whole.iterations and reduced.status is whole.status
    np.testing.assert_allclose(reduced.theta, whole.theta, rtol=1e-9, atol=1e-12)
    assert reduced.iterations > 3 and reduced.norm < 0.5 * reduced.initial_norm  # a solve of some length


@pytest.mark.parametrize("start", [[0.0, 2.0], [0.5, 2.0]], ids=["on_the_bound", "inside"])
def test_a_variable_its_bound_holds_leaves_the_step_to_the_others(start):
    """Linear least squares with nearly parallel columns whose unconstrained minimum lies beyond the
    box (x0 ≥ 0): the bound-constrained minimum is x0 = 0 and x1 the least squares of the second
    column alone. The step is the model's for the free variable only (`held_at_bounds`); a step for
    both clipped afterwards moves x1 as if x0 had moved too and creeps along the bound."""
    A = np.array([[1.0, 1.0], [1.0, 1.1], [0.0, 0.1]])
    b = np.array([1.0, 0.8, 0.5])
    assert np.linalg.lstsq(A, b, rcond=None)[0][0] < 0.0  # the premise: the bound is active
    p = Problem([VariableBlock("x", start, lower=[0.0, -np.inf])])
    p.add_residual(LinearBlock(("x",), [A], b))
    r = solve_hinged_lm(p, HingedParams(tolerance=0.0, max_iterations=30))
    assert r.status is Status.CONVERGED and r.iterations <= 8, r.reason
    a = A[:, 1]
    assert r.values["x"] == pytest.approx([0.0, a @ b / (a @ a)], abs=1e-10)


def test_marquardt_scale_of_shared_rows_is_the_sum_over_the_rows_they_stand_for():
    """`_HingeModel`'s scale over J_full = J[jrow] (a shared row once per residual row) by the cached
    gather of J's values (`_RowExpansion`) is the scale of J[jrow] built by scipy, bit for bit: the
    same entries in the same order. The expansion is reused while J's read-only index arrays are the
    same, and worked out again for another pattern or writeable arrays."""
    import scipy.sparse as sp

    from legplan.solve.hinged import _HingeModel, _RowExpansion
    from legplan.solve.lm import MARQUARDT_FLOOR

    rng = np.random.default_rng(3)
    expansion = _RowExpansion()
    for trial in range(30):
        m, n = int(rng.integers(1, 40)), int(rng.integers(1, 25))
        J = sp.random(m, n, density=rng.uniform(0.0, 0.6), format="csr", random_state=int(rng.integers(1 << 30)))
        J.indices.flags.writeable = J.indptr.flags.writeable = trial % 3 != 0
        jrow = np.sort(rng.integers(0, m, int(rng.integers(0, 2 * m + 1))))  # rows repeated, rows left out
        sign = np.where(rng.random(jrow.size) < 0.5, -1.0, 1.0)
        v = rng.normal(size=jrow.size)
        hinged = rng.random(jrow.size) < 0.5
        for _ in range(2):  # the second call reads the kept expansion where it may
            model = _HingeModel(J, v, hinged, n, rows=(jrow, sign), expansion=expansion)
            full = J[jrow]
            d2 = np.bincount(full.indices, weights=full.data ** 2, minlength=n)
            scale = np.where(d2 > MARQUARDT_FLOOR * d2.max(initial=0.0), 1.0 / np.sqrt(np.where(d2 > 0, d2, 1.0)), 1.0)
            assert np.array_equal(model.scale, scale)
        take, indices = expansion.of(J, jrow)
        assert np.array_equal(J.data[take], full.data) and np.array_equal(indices, full.indices)
        kept = expansion._take
        expansion.of(J, jrow)
        assert (expansion._take is kept) == (not J.indices.flags.writeable)


def test_lambda_falls_by_lambda_decrease_after_an_exact_model_step():
    """Linear rows with a weakly determined direction (scaled σ² about λ₀): every step is the model's
    exactly (ρ = 1), and λ falls by `lambda_decrease` per step; at Nielsen's ⅓ each damped step keeps
    about λ/(σ² + λ) of the residual along that direction: more steps to the tolerance."""
    runs = {}
    for decrease in (1 / 3, 1e-2):
        p = Problem([VariableBlock("x", [0.0, 0.0])])
        p.add_residual(LinearBlock(("x",), [np.array([[1.0, 1.0], [1.0, 1.02]])], np.array([1.0, 2.0])))
        runs[decrease] = r = solve_hinged_lm(p, HingedParams(tolerance=1e-10, lambda_decrease=decrease))
        assert r.status is Status.CONVERGED and r.rejected_steps == 0, r.reason
        assert r.lambda_history[:3] == pytest.approx([1e-4 * decrease ** k for k in (1, 2, 3)], rel=1e-6)
    assert runs[1e-2].iterations <= 4 < runs[1 / 3].iterations


def test_debug_trace_logs_every_step_with_its_predicted_and_actual_decrease(caplog):
    """At DEBUG level each step logs λ and the model's and the actual decrease of ‖h‖²: on linear rows
    the two agree (ρ = 1)."""
    import logging
    import re

    p = Problem([VariableBlock("x", [0.0, 0.0])])
    p.add_residual(LinearBlock(("x",), [np.array([[1.0, 1.0], [1.0, 1.02]])], np.array([1.0, 2.0])))
    with caplog.at_level(logging.DEBUG, logger="legplan.solve.hinged"):
        r = solve_hinged_lm(p, HingedParams(tolerance=1e-10))
    lines = [m for m in caplog.messages if m.startswith("step ")]
    assert len(lines) == r.iterations
    for line, lam in zip(lines, [1e-4] + r.lambda_history[:-1]):
        predicted, actual = (float(x) for x in re.search(r"predicted (\S+) actual (\S+);", line).groups())
        assert float(re.search(r"λ=(\S+) ", line).group(1)) == pytest.approx(lam, rel=1e-2)
        assert actual == pytest.approx(predicted, rel=1e-3)


def test_a_passed_deadline_stops_before_a_step_at_the_start():
    import time

    p = Problem([VariableBlock("x", [2.0, 2.0])])
    p.add_residual(LinearBlock(("x",), [np.array([[1.0, 1.0]])], 1.0))
    r = solve_hinged_lm(p, HingedParams(tolerance=1e-12), deadline=time.process_time())
    assert r.status is Status.TIME_LIMIT and r.stopped_by == "deadline" and r.iterations == 0
    assert r.values["x"].tolist() == [2.0, 2.0]
