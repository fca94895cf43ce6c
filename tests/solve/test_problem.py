"""Problem assembly: both assembly paths, fixed masks, bounds, weights, pattern reuse."""

import numpy as np
import pytest
import scipy.sparse as sp

from legplan.solve import FunctionBlock, LMParams, Problem, Status, VariableBlock, solve_lm
from legplan.solve.blocks import ResidualBlock
import testproblems as tp


def _quadratic_problem(fixed=None, weight=1.0, lower=-np.inf, upper=np.inf):
    """r = A x − b for x of size 4 plus r = y² − 1 for y of size 2, coupled through a third block."""
    rng = np.random.default_rng(1)
    A, b = rng.standard_normal((6, 4)), rng.standard_normal(6)
    problem = Problem([VariableBlock("x", np.zeros(4), fixed=fixed, lower=lower, upper=upper),
                       VariableBlock("y", [2.0, 3.0])])
    problem.add_residual(FunctionBlock(["x"], 6, lambda x: (A @ x - b, [A])), weight=weight)
    problem.add_residual(FunctionBlock(["y"], 2, lambda y: (y ** 2 - 1, [sp.diags(2 * y)])))
    problem.add_residual(FunctionBlock(["x", "y"], 1, lambda x, y: (np.array([x[0] * y[1]]),
                                                                    [np.array([[y[1], 0, 0, 0]]),
                                                                     np.array([[0, x[0]]])])))
    return problem, A, b


def test_blocks_and_stacked_assembly_agree_and_match_jacobian():
    problem, _, _ = _quadratic_problem(weight=np.arange(1.0, 7.0))
    theta = np.linspace(-1, 1, problem.layout.n)
    h, J = problem.jacobian(theta)
    blocks = problem.normal_equations(theta, "blocks")
    stacked = problem.normal_equations(theta, "stacked")
    for ne in (blocks, stacked):
        np.testing.assert_allclose(ne.residual, h)
        np.testing.assert_allclose(ne.hessian.toarray(), (J.T @ J).toarray(), atol=1e-12)
        np.testing.assert_allclose(ne.gradient, J.T @ h, atol=1e-12)
    for fixed in (None, [True, False, False, True]):  # with a fixed entry, its column is dropped
        problem, _, _ = _quadratic_problem(fixed=fixed, weight=np.arange(1.0, 7.0))
        theta = np.linspace(-1, 1, problem.layout.n)
        h, J = problem.jacobian(theta)
        only_j = problem.normal_equations(theta, "jacobian")
        assert only_j.hessian is None and sp.isspmatrix_csr(only_j.jacobian)
        np.testing.assert_array_equal(only_j.jacobian.toarray(), J.toarray())
        np.testing.assert_allclose(only_j.gradient, J.T @ h, atol=1e-12)


def test_nonzero_jacobian_has_the_values_of_jacobian_on_the_entries_ever_nonzero():
    for fixed in (None, [False, True, False, True]):
        problem, _, _ = _quadratic_problem(fixed=fixed, weight=np.arange(1.0, 7.0))
        zero_x = np.zeros(problem.layout.n)  # x = 0: the coupling row's ∂/∂y entry x[0] is zero
        zero_x[-2:] = [2.0, 3.0]  # y ≠ 0: its block's own (value-dependent) pattern stays whole
        theta = zero_x
        h, J = problem.jacobian(theta)
        h_nz, J_nz = problem.nonzero_jacobian(theta)
        assert sp.isspmatrix_csr(J_nz) and J_nz.nnz == np.count_nonzero(J.toarray()) < J.nnz
        np.testing.assert_array_equal(h_nz, h)
        np.testing.assert_array_equal(J_nz.toarray(), J.toarray())
        version = problem.nonzero_version
        theta = np.linspace(-1, 1, problem.layout.n)  # now nonzero: the pattern grows, once
        h, J = problem.jacobian(theta)
        h_nz, J_nz = problem.nonzero_jacobian(theta)
        np.testing.assert_array_equal(J_nz.toarray(), J.toarray())
        assert problem.nonzero_version == version + 1
        problem.nonzero_jacobian(zero_x)  # zero again: kept, pattern unchanged
        assert problem.nonzero_version == version + 1 and problem.nonzero_jacobian(theta)[1].nnz == J_nz.nnz


def test_weights_scale_rows():
    problem, A, b = _quadratic_problem(weight=2.0)
    h = problem.residual(np.zeros(problem.layout.n))
    np.testing.assert_allclose(h[:6], -2 * b)


def test_fixed_entries_have_no_column_and_keep_their_value():
    fixed = np.array([False, True, False, True])
    problem, A, b = _quadratic_problem(fixed=fixed)
    problem._variables[0].value[fixed] = [0.5, -0.25]
    assert problem.layout.n == 2 + 2
    result = solve_lm(problem)
    x = result.values["x"]
    np.testing.assert_array_equal(x[fixed], [0.5, -0.25])
    _, J = problem.jacobian(result.theta)
    assert J.shape == (9, 4)


def test_bounds_are_respected_and_active_at_solution():
    problem, A, b = _quadratic_problem(upper=0.05)
    result = solve_lm(problem)
    x = result.values["x"]
    assert np.all(x <= 0.05 + 1e-15)
    unconstrained = np.linalg.lstsq(A, b, rcond=None)[0]
    assert np.any(unconstrained > 0.05)  # the bound matters for this data
    assert np.any(np.isclose(x, 0.05))


def test_pattern_is_analysed_once_while_values_change():
    problem = tp.broyden_tridiagonal(50)
    first = problem.normal_equations(np.zeros(50))
    second = problem.normal_equations(np.ones(50))
    assert first.pattern_version == second.pattern_version
    assert not np.allclose(first.hessian.data, second.hessian.data)


def test_bad_blocks_are_rejected():
    problem = Problem([VariableBlock("x", np.zeros(2))])
    with pytest.raises(ValueError, match="unknown variables"):
        problem.add_residual(FunctionBlock(["z"], 1, lambda z: (z, [np.eye(1)])))
    with pytest.raises(ValueError, match="weight"):
        problem.add_residual(FunctionBlock(["x"], 2, lambda x: (x, [np.eye(2)])), weight=np.ones(3))
    problem.add_residual(FunctionBlock(["x"], 3, lambda x: (x, [np.eye(2)])))
    with pytest.raises(ValueError, match="declared size 3"):
        problem.residual(np.zeros(2))


def test_write_back_with_store():
    problem = tp.rosenbrock()
    result = solve_lm(problem)
    assert result.status is Status.CONVERGED
    problem.layout.store(result.theta)
    np.testing.assert_allclose(problem.layout.initial(), [1.0, 1.0], atol=1e-10)
    assert solve_lm(problem, LMParams()).iterations == 0


@pytest.mark.parametrize("assembly", ["blocks", "stacked"])
def test_sparse_jtj_entry_cancelling_to_zero_keeps_pattern_and_values(assembly):
    """JᵀJ of J = [[1, a], [1, −a]] has an off-diagonal 1·a − 1·a = 0 exactly at every a: the entry
    stays in the pattern (value 0) and every other value is right, whichever product path is taken."""
    def fn(x):
        J = sp.csr_matrix(np.array([[1.0, x[1]], [1.0, -x[1]], [0.0, x[0]]]))
        return np.array([x[0] + x[1] ** 2, x[0] - x[1] ** 2, x[0] * x[1]]), [J]
    problem = Problem([VariableBlock("x", [0.5, 2.0])])
    problem.add_residual(FunctionBlock(["x"], 3, fn))
    for theta in (np.array([0.5, 2.0]), np.array([0.0, 3.0]), np.array([1.5, -1.0])):
        ne = problem.normal_equations(theta, assembly)
        J = fn(theta)[1][0].toarray()
        assert ne.hessian.nnz == 4  # full 2×2 pattern, cancelled or not
        np.testing.assert_allclose(ne.hessian.toarray(), J.T @ J, rtol=1e-15, atol=0)


def test_residual_rows_give_the_needed_rows_and_skip_blocks_without_one():
    """`Problem.residual_rows`: the residual's values on the needed rows (scalar and per-row
    weights, a block's own `residual_rows` for a part of its rows, the augmented Lagrangian's bound
    rows), zero elsewhere; a block without a needed row is not evaluated."""
    from legplan.solve.auglag import Constraint, _AugmentedRows

    class Counted(ResidualBlock):
        def __init__(self, name, size, matrix):
            self.variables, self.size, self.matrix, self.calls = (name,), size, matrix, 0

        def evaluate(self, values, jacobians):
            self.calls += 1
            x = values[0]
            return np.sin(self.matrix @ x) + x.sum(), ([np.cos(self.matrix @ x)[:, None] * self.matrix + 1.0]
                                                       if jacobians else None)

    rng = np.random.default_rng(1)
    a, b = VariableBlock("a", rng.standard_normal(4)), VariableBlock("b", rng.standard_normal(3))
    first, second, third = (Counted("a", 5, rng.standard_normal((5, 4))), Counted("b", 6, rng.standard_normal((6, 3))),
                            Counted("a", 4, rng.standard_normal((4, 4))))
    bounded = _AugmentedRows(Constraint(third, np.array([-1.0, -np.inf, 0.0, -0.5]), np.array([1.0, 0.5, 0.0, np.inf]),
                                        name="bounded", scale=np.array([1.0, 2.0, 3.0, 4.0])))
    bounded.mu, bounded.y = 4.0, rng.random(bounded.size)
    problem = Problem([a, b])
    problem.add_residual(first, 0.5)
    problem.add_residual(second, rng.random(6) + 0.5)
    problem.add_residual(bounded)
    theta = problem.layout.initial() + 0.1
    whole = problem.residual(theta)
    sizes = (5, 6, bounded.size)
    for needed_blocks in ((True, False, True), (False, True, False)):
        needed = np.concatenate([rng.random(n) < 0.5 if on else np.zeros(n, bool) for n, on in zip(sizes, needed_blocks)])
        needed[0] = needed_blocks[0]
        needed[5] = needed_blocks[1]
        needed[11] = needed_blocks[2]
        calls = [first.calls, second.calls, third.calls]
        got = problem.residual_rows(theta, needed)
        np.testing.assert_allclose(got[needed], whole[needed], rtol=1e-15, atol=1e-15)
        assert not got[~needed].any()
        assert [first.calls - calls[0], second.calls - calls[1], third.calls - calls[2]] == [int(on) for on in needed_blocks]
