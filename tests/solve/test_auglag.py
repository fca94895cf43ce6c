"""Augmented Lagrangian over the hinged LM: equality and bound constraints, costs, stalls."""

import numpy as np
import scipy.sparse as sp
import pytest

from legplan.solve import FunctionBlock, Status, VariableBlock
from legplan.solve.auglag import ALParams, Constraint, CostTerm, solve_augmented_lagrangian
from legplan.solve.blocks import LinearBlock


def _circle(x):  # x0² + x1² (one row)
    return np.array([x[0] ** 2 + x[1] ** 2]), [np.array([[2 * x[0], 2 * x[1]]])]


def test_cost_with_equality_constraint_reaches_the_kkt_point():
    # min (x0 − 2)² + (x1 − 1)²  s.t.  x0² + x1² = 1  →  x = (2, 1)/√5
    cost = LinearBlock(("x",), [np.eye(2)], np.array([2.0, 1.0]))
    k = Constraint(FunctionBlock(("x",), 1, _circle), 1.0, 1.0, name="circle")
    r = solve_augmented_lagrangian([VariableBlock("x", [0.5, 0.0])], [CostTerm("target", cost, 1.0)], [k])
    assert r.success, r.reason
    assert r.values["x"] == pytest.approx(np.array([2.0, 1.0]) / np.sqrt(5), abs=2e-3)
    assert r.max_violation <= 1e-3
    assert r.violations["circle"] == r.max_violation


def test_bound_constraint_active_and_inactive():
    cost = LinearBlock(("x",), [np.eye(2)], np.array([3.0, -1.0]))
    box = Constraint(LinearBlock(("x",), [np.eye(2)]), [-np.inf, 0.0], [1.0, np.inf], name="box")
    r = solve_augmented_lagrangian([VariableBlock("x", [0.0, 0.0])], [CostTerm("target", cost, 2.0)], [box])
    assert r.success, r.reason
    assert r.values["x"] == pytest.approx([1.0, 0.0], abs=2e-3)  # both bounds active
    assert r.cost_terms["target"] == pytest.approx(0.5 * 2.0 * (4.0 + 1.0), rel=1e-2)


def test_feasibility_problem_without_costs_meets_the_tolerance_in_raw_units():
    # two circles: the scale weighs the rows, the tolerance stays in the block's units
    k1 = Constraint(FunctionBlock(("x",), 1, _circle), 4.0, 4.0, scale=1e-3)
    k2 = Constraint(LinearBlock(("x",), [np.array([[1.0, -1.0]])]), 0.0, np.inf, scale=10.0)  # x0 ≥ x1
    r = solve_augmented_lagrangian([VariableBlock("x", [3.0, 0.5])], [], [k1, k2])
    assert r.success and r.outer_iterations == 1
    x = r.values["x"]
    assert abs(x @ x - 4.0) <= 1e-3 and x[0] - x[1] >= -1e-3


def test_exact_rows_stops_once_every_row_is_within_tolerance_in_its_own_units():
    """Rows of very different scales: the norm test must reach the smallest scale's precision on
    every row; the exact test stops as soon as each row meets the tolerance in its own units."""
    def double_root(x):  # (x0 − 1)² = 0: Gauss-Newton halves the distance per step
        return np.array([(x[0] - 1.0) ** 2]), [np.array([[2.0 * (x[0] - 1.0), 0.0]])]

    k1 = Constraint(FunctionBlock(("x",), 1, _circle), 4.0, 4.0, scale=1e-3)
    k2 = Constraint(FunctionBlock(("x",), 1, double_root), 0.0, 0.0, scale=10.0)
    runs = {exact: solve_augmented_lagrangian([VariableBlock("x", [3.0, 0.5])], [], [k1, k2],
                                              ALParams(exact_rows=exact)) for exact in (False, True)}
    for r in runs.values():
        x = r.values["x"]
        assert r.success and abs(x @ x - 4.0) <= 1e-3 and (x[0] - 1.0) ** 2 <= 1e-3
    assert runs[True].iterations < runs[False].iterations
    assert runs[True].history[-1]["stopped_by"] == "row_tolerance"


def test_scaled_tolerance_loosens_only_the_rows_of_a_small_scale():
    """`scaled_tolerance`: a row scaled by 1e-3 (a force per the robot's weight) may keep 1e-3 / 1e-3 = 1
    of its units, one scaled by 10 keeps `violation_tolerance`; Gauss-Newton halves each distance
    per step, so the loosened solve stops earlier, every row within its own tolerance."""
    def double_roots(x):  # (x0 − 1)², (x1 − 1)²
        return (x - 1.0) ** 2, [np.diag(2.0 * (x - 1.0))]

    from legplan.solve.auglag import row_tolerances

    def constraints():
        rows = FunctionBlock(("x",), 2, double_roots)
        return [Constraint(rows, 0.0, 0.0, scale=np.array([1e-3, 10.0]))]

    loose = ALParams(exact_rows=True, scaled_tolerance=1e-3)
    assert np.allclose(row_tolerances(constraints(), loose)[0], [1.0, 1e-3])
    assert np.allclose(row_tolerances(constraints(), ALParams())[0], [1e-3, 1e-3])
    runs = {p.scaled_tolerance: solve_augmented_lagrangian([VariableBlock("x", [3.0, 1.1])], [], constraints(), p)
            for p in (ALParams(exact_rows=True), loose)}
    for tolerance, r in runs.items():
        c = (r.values["x"] - 1.0) ** 2
        assert r.success and c[1] <= 1e-3 and c[0] <= max(1e-3, tolerance / 1e-3)
    assert (runs[1e-3].values["x"][0] - 1.0) ** 2 > 1e-3  # the loosened row kept more than violation_tolerance
    assert runs[1e-3].iterations < runs[0.0].iterations


def test_infeasible_constraints_are_reported_as_failure():
    a = Constraint(LinearBlock(("x",), [np.array([[1.0]])]), 1.0, 1.0, name="a")
    b = Constraint(LinearBlock(("x",), [np.array([[1.0]])]), -np.inf, 0.0, name="b")
    r = solve_augmented_lagrangian([VariableBlock("x", [0.0])], [], [a, b], ALParams(max_iterations=200))
    assert not r.success
    assert r.max_violation == pytest.approx(0.5, abs=1e-2)  # the least-squares compromise x = 0.5
    assert r.status in (Status.STALLED, Status.MAX_ITERATIONS)


def test_constraint_bounds_are_validated():
    with pytest.raises(ValueError):
        Constraint(LinearBlock(("x",), [np.eye(2)]), [1.0, 0.0], [0.0, 1.0])


def _multipliers(variables, costs, constraints):
    """least_squares_multipliers on the problem solve_augmented_lagrangian would build."""
    from legplan.solve.auglag import _AugmentedRows, least_squares_multipliers
    from legplan.solve.problem import Problem

    problem = Problem(variables)
    for term in costs:
        problem.add_residual(term.block, np.sqrt(term.weight))
    rows = [problem.add_residual(_AugmentedRows(k)) for k in constraints]
    least_squares_multipliers(problem, rows, problem.layout.initial(), 1e-4)
    return [r.y for r in rows]


def test_least_squares_multipliers_are_the_kkt_multipliers_at_the_solution():
    # at x* = (2, 1)/√5 on the circle: ∇f + y∇c = 0 with ∇f = x* − a, ∇c = 2x*  →  y = (√5 − 1)/2
    x = np.array([2.0, 1.0]) / np.sqrt(5)
    cost = LinearBlock(("x",), [np.eye(2)], np.array([2.0, 1.0]))
    circle = Constraint(FunctionBlock(("x",), 1, _circle), 1.0, 1.0)
    far = Constraint(LinearBlock(("x",), [np.eye(2)]), -5.0, 5.0)  # inactive box: no multiplier
    (y_circle, y_far) = _multipliers([VariableBlock("x", x)], [CostTerm("target", cost, 1.0)], [circle, far])
    assert y_circle == pytest.approx([(np.sqrt(5) - 1) / 2], rel=1e-6)
    assert np.all(y_far == 0.0)


def test_least_squares_multipliers_of_bounds_are_nonnegative():
    # x = 1 at both bounds x ≤ 1 (pushed against by the cost toward 3) and x ≥ 1 (pulled away from):
    # only the upper bound carries the cost's pull, y = 2; the lower one's least-squares share is dropped
    cost = LinearBlock(("x",), [np.eye(1)], np.array([3.0]))
    upper = Constraint(LinearBlock(("x",), [np.eye(1)]), -np.inf, 1.0)
    lower = Constraint(LinearBlock(("x",), [np.eye(1)]), 1.0, np.inf)
    y_upper, y_lower = _multipliers([VariableBlock("x", [1.0])], [CostTerm("target", cost, 1.0)], [upper, lower])
    assert y_upper == pytest.approx([2.0], rel=1e-6) and y_lower == pytest.approx([0.0], abs=1e-12)


def test_least_squares_start_from_the_solution_stays_there():
    x = np.array([2.0, 1.0]) / np.sqrt(5)
    cost = LinearBlock(("x",), [np.eye(2)], np.array([2.0, 1.0]))
    circle = Constraint(FunctionBlock(("x",), 1, _circle), 1.0, 1.0)
    params = ALParams(multipliers="least_squares", mu_init=10.0)
    r = solve_augmented_lagrangian([VariableBlock("x", x)], [CostTerm("target", cost, 1.0)], [circle], params)
    assert r.success and r.outer_iterations <= 2
    assert r.values["x"] == pytest.approx(x, abs=1e-4)


def test_least_squares_start_at_the_solution_converges_in_one_outer_iteration():
    """With estimated multipliers the start is a point of the outer iteration: the first subproblem's
    cost change is measured from it, so a start at the KKT point needs no second subproblem to confirm."""
    x = np.array([2.0, 1.0]) / np.sqrt(5)
    cost = LinearBlock(("x",), [np.eye(2)], np.array([2.0, 1.0]))
    circle = Constraint(FunctionBlock(("x",), 1, _circle), 1.0, 1.0)
    r = solve_augmented_lagrangian([VariableBlock("x", x)], [CostTerm("target", cost, 1.0)], [circle],
                                   ALParams(multipliers="least_squares", mu_init=10.0))
    assert r.success and r.outer_iterations == 1 and r.iterations == 1
    zero = solve_augmented_lagrangian([VariableBlock("x", x)], [CostTerm("target", cost, 1.0)], [circle],
                                      ALParams(mu_init=10.0))
    assert zero.outer_iterations >= 2  # zero multipliers: the first subproblem's change is no test


def test_settled_exit_stops_once_the_cost_settled_and_leaves_the_rows_outside_tolerance():
    """`settled_exit`: a soft penalty leaves the circle 4e-3 off after the first subproblem while the cost
    has settled; the solve stops there (not converged, for a constraints-alone stage to finish) instead
    of raising μ over further outer iterations."""
    x = 1.002 * np.array([2.0, 1.0]) / np.sqrt(5)
    cost = LinearBlock(("x",), [np.eye(2)], np.array([2.0, 1.0]))
    circle = Constraint(FunctionBlock(("x",), 1, _circle), 1.0, 1.0)
    soft = ALParams(multipliers="least_squares", mu_init=1e-2)
    stopped = solve_augmented_lagrangian([VariableBlock("x", x)], [CostTerm("target", cost, 1.0)], [circle],
                                         ALParams(multipliers="least_squares", mu_init=1e-2, settled_exit=True))
    assert stopped.status is Status.MAX_ITERATIONS and "cost settled" in stopped.reason
    assert stopped.outer_iterations == 1 and stopped.max_violation > soft.violation_tolerance
    full = solve_augmented_lagrangian([VariableBlock("x", x)], [CostTerm("target", cost, 1.0)], [circle], soft)
    assert full.success and full.outer_iterations > 1


def test_row_picker_scales_picked_rows_keeping_explicit_zeros_and_follows_a_new_pattern():
    """diag(factor)·J[pick] with rows picked twice (both bounds of a row), explicit zeros kept, and
    recomputed when the Jacobian's pattern changes; dense Jacobians too."""
    import scipy.sparse as sp

    from legplan.solve.auglag import _RowPicker

    pick = np.array([2, 0, 2, 1])
    factor = np.array([1.0, -2.0, 3.0, 0.5])
    J = sp.csr_matrix((np.array([1.0, 0.0, 2.0, 3.0, 4.0]), np.array([0, 2, 1, 0, 2]), np.array([0, 2, 3, 5])),
                      shape=(3, 3))  # row 0 has an explicit zero at column 2
    picker = _RowPicker(pick)
    for values in ([1.0, 0.0, 2.0, 3.0, 4.0], [5.0, 6.0, 7.0, 8.0, 9.0]):  # same pattern, new values
        J.data = np.array(values)
        out = picker(J, factor)
        assert np.allclose(out.toarray(), factor[:, None] * J.toarray()[pick])
        assert out.nnz == sum(np.diff(J.indptr)[pick])  # the explicit zero kept its place
    other = sp.csr_matrix(np.array([[0.0, 1.0, 0.0], [2.0, 0.0, 0.0], [0.0, 0.0, 3.0]]))  # another pattern
    assert np.allclose(picker(other, factor).toarray(), factor[:, None] * other.toarray()[pick])
    dense = np.arange(9.0).reshape(3, 3)
    assert np.allclose(picker(dense, factor), factor[:, None] * dense[pick])


def test_problem_structure_cache_is_emptied_when_a_block_is_added():
    from legplan.solve import Problem, VariableBlock
    from legplan.solve.blocks import LinearBlock

    problem = Problem([VariableBlock("x", np.zeros(2))])
    problem.add_residual(LinearBlock(("x",), [np.eye(2)]))
    problem.structure_cache["normal_pattern"] = object()
    problem.add_residual(LinearBlock(("x",), [np.ones((1, 2))]))
    assert problem.structure_cache == {}


@pytest.mark.parametrize("shape", [(40, 7), (7, 40)])
def test_least_norm_multipliers_agree_on_either_side_of_the_push_through_identity(shape):
    """Tall (many sample rows over few coefficients) and wide: −(A Aᵀ + δI)⁻¹ A g, dense, with a zero
    row (a dropped bound row), a zero column (a variable no active row touches) and duplicated rows."""
    from legplan.solve.auglag import _least_norm_multipliers
    from legplan.solve.linsolve import make_solver

    rng = np.random.default_rng(4)
    dense = rng.normal(size=shape) * (rng.random(shape) < 0.4)
    dense[1] = 0.0
    dense[:, 2] = 0.0
    dense[3] = dense[4]
    g, delta = rng.normal(size=shape[1]), 1e-6
    expected = -np.linalg.solve(dense @ dense.T + delta * np.eye(shape[0]), dense @ g)
    got = _least_norm_multipliers(make_solver("cholmod"), sp.csr_matrix(dense), g, delta)
    np.testing.assert_allclose(got, expected, rtol=1e-7, atol=1e-9)
    assert got[1] == 0.0 and got[3] == pytest.approx(got[4], rel=1e-9)


def _four_rows(x):
    """c(x) = [x0² + x1², x0·x1, sin x0 + x1, x0 − x1] and its Jacobian."""
    return (np.array([x[0] ** 2 + x[1] ** 2, x[0] * x[1], np.sin(x[0]) + x[1], x[0] - x[1]]),
            [np.array([[2 * x[0], 2 * x[1]], [x[1], x[0]], [np.cos(x[0]), 1.0], [1.0, -1.0]])])


# one equality, one two-sided, one upper-only and one lower-only row
_LOWER, _UPPER = np.array([1.0, -0.2, -np.inf, -1.0]), np.array([1.0, 0.2, 3.0, np.inf])


def test_two_sided_rows_share_one_jacobian_row_that_gives_each_bounds_derivative():
    """A row bounded on both sides is two residual rows (its upper and its lower bound) on one
    Jacobian row: diag(sign)·J[jrow] (`Problem.row_map`) is the finite-difference Jacobian of every
    residual row, at several μ and multipliers; J has one row fewer than the residual."""
    from legplan.solve import Problem
    from legplan.solve.auglag import _AugmentedRows
    from legplan.solve.jaccheck import numeric_jacobian

    k = Constraint(FunctionBlock(("x",), 4, _four_rows), _LOWER, _UPPER, scale=[1.0, 2.0, 0.5, 3.0])
    problem = Problem([VariableBlock("x", [0.3, -0.4])])
    rows = problem.add_residual(_AugmentedRows(k))
    jrow, sign = problem.row_map()
    assert rows.size == 5 and jrow.tolist() == [0, 1, 2, 1, 3] and sign.tolist() == [1, 1, 1, -1, 1]
    rng = np.random.default_rng(2)
    for mu in (1.0, 1e3):
        rows.mu, rows.y = mu, np.abs(rng.standard_normal(rows.size))
        theta = rng.standard_normal(2)
        v, J = problem.jacobian(theta)
        assert J.shape == (4, 2)
        full = sign[:, None] * J.toarray()[jrow]
        assert v == pytest.approx(problem.residual(theta))
        np.testing.assert_allclose(full, numeric_jacobian(problem.residual, theta), rtol=1e-6, atol=1e-6 * np.sqrt(mu))


@pytest.mark.parametrize("target", [(2.0, 1.5), (2.0, -1.5)])  # x0·x1 at its upper, at its lower bound
def test_two_sided_rows_solve_as_the_two_bounds_given_apart(target):
    """The same constrained problem with each two-sided row once (a shared Jacobian row) and with
    its bounds as two one-sided constraints (a Jacobian row each, the residual rows in the same
    order): the same solution bit for bit (the map changes no sum), with either bound of the
    two-sided row active."""
    cost = LinearBlock(("x",), [np.eye(2)], np.array(target))
    block = FunctionBlock(("x",), 4, _four_rows)
    together = [Constraint(block, _LOWER, _UPPER)]
    apart = [Constraint(block, np.where(_LOWER == _UPPER, _LOWER, -np.inf), _UPPER),
             Constraint(block, np.where(_LOWER == _UPPER, -np.inf, _LOWER), np.inf)]
    runs = [solve_augmented_lagrangian([VariableBlock("x", [0.9, 0.1])], [CostTerm("target", cost, 1.0)], k,
                                       ALParams(mu_init=10.0)) for k in (together, apart)]
    for r in runs:
        assert r.success, r.reason
    x = runs[0].values["x"]
    assert x[0] * x[1] == pytest.approx(0.2 * np.sign(target[1]), abs=2e-3)  # the bound the target pulls to
    assert np.array_equal(x, runs[1].values["x"])
    assert runs[0].iterations == runs[1].iterations and runs[0].outer_iterations == runs[1].outer_iterations


def test_two_sided_rows_with_a_variable_held_at_its_box_solve_as_the_bounds_given_apart():
    """min ‖x − (2, 4)‖² with x0 ≤ 1.5 (the variable's box, held there) and −1 ≤ x0 − x1 ≤ 1 (its
    lower bound active): x = (1.5, 2.5), bit for bit the same with the two bounds as separate
    constraints."""
    cost = LinearBlock(("x",), [np.eye(2)], np.array([2.0, 4.0]))
    block = LinearBlock(("x",), [np.array([[1.0, -1.0]])])
    runs = []
    for k in ([Constraint(block, -1.0, 1.0)], [Constraint(block, -np.inf, 1.0), Constraint(block, -1.0, np.inf)]):
        variables = [VariableBlock("x", [0.0, 0.0], upper=[1.5, np.inf])]
        runs.append(solve_augmented_lagrangian(variables, [CostTerm("target", cost, 1.0)], k, ALParams(mu_init=10.0)))
        assert runs[-1].success, runs[-1].reason
    assert runs[0].values["x"] == pytest.approx([1.5, 2.5], abs=2e-3)
    assert np.array_equal(runs[0].values["x"], runs[1].values["x"])
    assert runs[0].iterations == runs[1].iterations


def _random_jacobian(rng) -> sp.csr_matrix:
    """A random sparse J (CSR, up to 40 × 30, empty rows likely), with 64-bit index arrays at times."""
    m, n = int(rng.integers(1, 40)), int(rng.integers(1, 30))
    J = sp.random(m, n, density=rng.uniform(0.0, 0.5), format="csr", random_state=int(rng.integers(1 << 30)))
    if rng.random() < 0.3:
        J.indices, J.indptr = J.indices.astype(np.int64), J.indptr.astype(np.int64)
    return J


def test_picked_pattern_is_scipys_row_selection():
    """`_picked_pattern` (each picked row's run of entries, written down) gives what scipy's row
    indexing J[pick] gives, array by array and dtype by dtype: the entry numbers (J's entries
    numbered 1.., picked), indices and row pointers; rows picked twice, none, empty rows, 32- and
    64-bit index arrays."""
    from legplan.solve.auglag import _picked_pattern

    rng = np.random.default_rng(5)
    for _ in range(200):
        J = _random_jacobian(rng)
        m = J.shape[0]
        pick = rng.integers(0, m, int(rng.integers(0, 2 * m + 1))).astype(np.int64)
        source, indices, indptr, row = _picked_pattern.__wrapped__(
            J.shape, J.indptr.dtype.str, J.indptr.tobytes(), J.indices.dtype.str, J.indices.tobytes(), pick.tobytes())
        numbers = sp.csr_matrix((np.arange(1.0, J.nnz + 1.0), J.indices, J.indptr), shape=J.shape)[pick]
        expect = (numbers.data.astype(np.int64) - 1, numbers.indices, numbers.indptr,
                  np.repeat(np.arange(pick.size), np.diff(numbers.indptr)))
        for got, want in zip((source, indices, indptr, row), expect):
            assert got.dtype == want.dtype and np.array_equal(got, want)


def test_constraint_values_reuse_the_last_plain_evaluation_at_the_same_values_only():
    """`_AugmentedRows.constraint_values` gives the constraint's values c(θ) of its last evaluation
    without Jacobians when it is asked at those very values (no evaluation of the block), and
    evaluates the block otherwise: at other values, and after a Jacobian evaluation only (which a
    block may form another way)."""
    from legplan.solve.auglag import _AugmentedRows

    calls = []

    def fn(x):
        calls.append(x.copy())
        return np.array([x[0] ** 2 + x[1], np.sin(x[1])]), [np.array([[2 * x[0], 1.0], [0.0, np.cos(x[1])]])]

    rows = _AugmentedRows(Constraint(FunctionBlock(["x"], 2, fn), [-1.0, -np.inf], [1.0, 0.5]))
    x = np.array([0.3, -0.2])
    rows.evaluate([x], False)
    assert len(calls) == 1
    c = rows.constraint_values([x.copy()])  # equal values, another array
    assert len(calls) == 1 and np.array_equal(c, [x[0] ** 2 + x[1], np.sin(x[1])])
    x[1] = 0.4  # the caller's array changed in place: its values are new ones
    assert np.array_equal(rows.constraint_values([x]), [x[0] ** 2 + x[1], np.sin(x[1])]) and len(calls) == 2
    y = np.array([0.3, -0.1])
    assert np.array_equal(rows.constraint_values([y]), [y[0] ** 2 + y[1], np.sin(y[1])]) and len(calls) == 3
    rows.evaluate([y], True)  # a Jacobian evaluation is not reused
    rows.constraint_values([y])
    assert len(calls) == 5


def test_reported_violations_are_those_of_the_constraints_at_the_solution():
    """The solve's violations and scaled violation (from the constraint values it reuses) equal those
    of the constraints evaluated afresh at the returned values, bit for bit."""
    from legplan.solve.auglag import scaled_violation

    def circle_fn(x):
        return np.array([x @ x]), [2 * x[None]]

    def line_fn(x):
        return np.array([x[0] - 2 * x[1]]), [np.array([[1.0, -2.0]])]

    constraints = [Constraint(FunctionBlock(["x"], 1, circle_fn), 1.0, 1.0, "circle", 10.0),
                   Constraint(FunctionBlock(["x"], 1, line_fn), -np.inf, 0.1, "line", 0.5)]
    r = solve_augmented_lagrangian([VariableBlock("x", np.array([1.5, -0.4]))], [], constraints)
    c = [k.block.evaluate([r.values["x"]], False)[0] for k in constraints]
    assert r.success
    assert r.violations == {k.name: float(k.violation(v).max()) for k, v in zip(constraints, c)}
    assert r.scaled_violation == scaled_violation(constraints, c)

def test_row_picker_of_every_row_in_order_takes_the_values_as_they_are():
    """`_RowPicker` of a pick that keeps every entry in its place (every row once, in order: a
    constraint bounded on both sides, or all equalities) skips the gather and gives scipy's diag(factor)·J[pick] bit for bit, as the
    picker of any other pick does."""
    from legplan.solve.auglag import _RowPicker

    rng = np.random.default_rng(11)
    for _ in range(40):
        m, n = int(rng.integers(1, 30)), int(rng.integers(1, 20))
        J = sp.random(m, n, density=rng.uniform(0.0, 0.6), format="csr", random_state=int(rng.integers(1 << 30)))
        for pick in (np.arange(m), rng.integers(0, m, int(rng.integers(0, 2 * m + 1)))):
            picker = _RowPicker(pick)
            factor = rng.normal(size=pick.size)
            for _ in range(2):  # the pattern worked out, then kept
                got, want = picker(J, factor), J[pick]
                assert np.array_equal(got.indptr, want.indptr) and np.array_equal(got.indices, want.indices)
                assert np.array_equal(got.data, want.data * np.repeat(factor, np.diff(want.indptr)))
            numbers = sp.csr_matrix((np.arange(J.nnz), J.indices, J.indptr), shape=J.shape)[pick].data
            assert (picker.pattern[3] is None) == np.array_equal(numbers, np.arange(J.nnz))  # the gather is the identity
            if np.array_equal(pick, np.arange(m)):
                assert picker.pattern[3] is None


def test_a_deadline_stops_the_solve_where_it_is_and_one_ahead_changes_nothing():
    """`deadline` (CPU clock): passed before the first step, the solve returns its start with
    `Status.TIME_LIMIT` and no iteration; one far ahead gives the solve without a deadline, bit for bit."""
    import time

    def solve(deadline):
        k1 = Constraint(FunctionBlock(("x",), 1, _circle), 4.0, 4.0, scale=1e-3)
        k2 = Constraint(LinearBlock(("x",), [np.array([[1.0, -1.0]])]), 0.0, np.inf, scale=10.0)
        return solve_augmented_lagrangian([VariableBlock("x", [3.0, 0.5])], [], [k1, k2], deadline=deadline)

    late = solve(time.process_time())
    assert late.status is Status.TIME_LIMIT and late.iterations == 0 and not late.success
    assert late.values["x"].tolist() == [3.0, 0.5] and "CPU time" in late.reason
    free, ahead = solve(None), solve(time.process_time() + 1e6)
    assert free.success and ahead.status is free.status
    assert ahead.values["x"].tolist() == free.values["x"].tolist() and ahead.iterations == free.iterations


def test_row_picker_of_every_row_is_the_picked_pattern():
    """A pick of every row in order (`_every_row_pattern`) gives the arrays `_picked_pattern` gives,
    dtype by dtype; a picker's J is then J scaled row by row, its entries in place."""
    from legplan.solve.auglag import _every_row_pattern, _picked_pattern, _RowPicker

    rng = np.random.default_rng(8)
    for _ in range(100):
        J = _random_jacobian(rng)
        m = J.shape[0]
        pick = np.arange(m, dtype=np.int64)
        expect = _picked_pattern.__wrapped__(J.shape, J.indptr.dtype.str, J.indptr.tobytes(), J.indices.dtype.str,
                                             J.indices.tobytes(), pick.tobytes())
        for got, want in zip(_every_row_pattern(J.shape, J.indptr, J.indices), expect):
            assert got.dtype == want.dtype and np.array_equal(got, want) and not got.flags.writeable
        factor = rng.normal(size=m)
        picked = _RowPicker(pick)(J, factor)
        assert np.array_equal(picked.toarray(), factor[:, None] * J.toarray())


def test_augmented_rows_scaling_follows_mu_and_the_multipliers():
    """The kept row scaling of `_AugmentedRows` (`_scaling`) is made again when μ or the multipliers
    change: its residual is √μ·(w(c − b)·sign + y/μ) at the current μ and y, every time."""
    from legplan.solve.auglag import _AugmentedRows

    block = FunctionBlock(["x"], 3, lambda x: (np.array([x[0], x[1] ** 2, x[0] - x[1]]),
                                               [np.array([[1.0, 0.0], [0.0, 2 * x[1]], [1.0, -1.0]])]))
    k = Constraint(block, [-1.0, 0.0, 0.5], [1.0, np.inf, 0.5], scale=[2.0, 3.0, 4.0])
    rows = _AugmentedRows(k)
    x = np.array([0.7, -1.2])
    c = block.evaluate([x], False)[0]

    def expected():
        root = np.sqrt(rows.mu)
        return root * rows.sign * k.scale[rows.pick] * (c[rows.pick] - rows.bound) + rows.y / root

    for mu, update in ((1.0, False), (10.0, False), (10.0, True), (100.0, True)):
        rows.mu = mu
        if update:
            rows.update(c)
        r, _ = rows.evaluate([x], False)
        r_jac, jacs = rows.evaluate([x], True)
        assert np.array_equal(r, expected()) and np.array_equal(r_jac, expected())
        full = np.asarray(block.evaluate([x], True)[1][0])
        picked = np.sqrt(mu) * rows.sign * k.scale[rows.pick]
        dense = jacs[0].toarray() if sp.issparse(jacs[0]) else np.asarray(jacs[0])
        want = (picked[:, None] * full[rows.pick]) if rows._jacobian_pick is None else \
            (picked[rows._jacobian_pick][:, None] * full[rows.pick[rows._jacobian_pick]])
        assert np.array_equal(dense, want)
    rows.y = np.ones(rows.size)  # a new multipliers' array, as the solver hands over
    assert np.array_equal(rows.evaluate([x], False)[0], expected())
