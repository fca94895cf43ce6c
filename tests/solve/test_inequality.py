"""Inequality wrappers: values, Jacobians, kept sparsity pattern, feasible solutions."""

import numpy as np
import pytest
import scipy.sparse as sp

from legplan.solve import (FunctionBlock, HingeInequality, IntervalPenalty, Problem, Status, VariableBlock,
                           check_jacobian, solve_lm)


def _identity_block(n, sparse=False):
    return FunctionBlock(["x"], n, lambda x: (x.copy(), [sp.identity(n, format="csr") if sparse else np.eye(n)]))


@pytest.mark.parametrize("sparse", [False, True])
def test_hinge_is_max_g_zero_with_masked_jacobian(sparse):
    block = HingeInequality(_identity_block(4, sparse))
    x = np.array([-1.0, 0.5, -0.2, 2.0])
    r, (J,) = block.evaluate([x], True)
    np.testing.assert_array_equal(r, [0, 0.5, 0, 2.0])
    dense = J.toarray() if sparse else J
    np.testing.assert_array_equal(dense, np.diag([0, 1.0, 0, 1.0]))
    if sparse:
        assert J.nnz == 4  # inactive rows keep their (zero) entries: the pattern does not change
    assert check_jacobian(block, [x]).max_abs_error < 1e-8


def test_interval_penalty_teb_style_margin():
    block = IntervalPenalty(_identity_block(5), lower=-1.0, upper=1.0, epsilon=0.1)
    x = np.array([-2.0, -0.95, 0.0, 0.95, 1.5])
    r, (J,) = block.evaluate([x], True)
    np.testing.assert_allclose(r, [1.1, 0.05, 0.0, 0.05, 0.6])
    np.testing.assert_array_equal(np.diag(J), [-1, -1, 0, 1, 1])
    assert check_jacobian(block, [x]).max_abs_error < 1e-8
    with pytest.raises(ValueError):
        IntervalPenalty(_identity_block(2), lower=0.0, upper=0.1, epsilon=0.1)


def test_solutions_satisfy_inequalities():
    # pull x towards (2, -3) while keeping x0 + x1 ≤ 0 (hinge) and x within [-1, 1] (interval, margin)
    target = np.array([2.0, -3.0])
    problem = Problem([VariableBlock("x", np.zeros(2))])
    problem.add_residual(FunctionBlock(["x"], 2, lambda x: (x - target, [np.eye(2)])), weight=0.1)
    problem.add_residual(HingeInequality(FunctionBlock(["x"], 1, lambda x: (np.array([x.sum() + 0.5]),
                                                                            [np.ones((1, 2))]))), weight=100.0)
    problem.add_residual(IntervalPenalty(_identity_block(2), -1.0, 1.0, epsilon=0.05), weight=100.0)
    result = solve_lm(problem)
    assert result.status in (Status.STALLED, Status.MAX_ITERATIONS)  # nonzero minimum of a kinked penalty
    x = result.values["x"]
    assert x.sum() + 0.5 <= 1e-3
    assert np.all(np.abs(x) <= 1.0 - 0.05 + 1e-3)


def test_hinge_root_is_feasible_and_exact():
    # the unit circle together with x0 − 0.5 ≤ 0: LM must slide along the circle to a feasible root
    problem = Problem([VariableBlock("x", [2.0, 0.1])])
    problem.add_residual(FunctionBlock(["x"], 1, lambda x: (np.array([x @ x - 1]), [2 * x[None, :]])))
    problem.add_residual(HingeInequality(FunctionBlock(["x"], 1, lambda x: (x[:1] - 0.5, [np.array([[1.0, 0.0]])]))))
    result = solve_lm(problem)
    assert result.status is Status.CONVERGED, result.reason
    x = result.values["x"]
    assert x[0] <= 0.5 + 1e-10
    assert abs(x @ x - 1) < 1e-10
