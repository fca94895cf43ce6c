"""legplan LM reaches the same minimum as scipy.optimize.least_squares on standard problems."""

import numpy as np
import pytest
from scipy.optimize import least_squares

from legplan.solve import LMParams, Status, solve_lm
import testproblems as tp

CASES = {
    "rosenbrock": (tp.rosenbrock, np.array([1.0, 1.0])),
    "powell_singular": (tp.powell_singular, np.zeros(4)),
    "brown_almost_linear": (tp.brown_almost_linear, np.ones(10)),
    "broyden_tridiagonal_10000": (lambda: tp.broyden_tridiagonal(10_000), None),
}


def _scipy_reference(problem, sparse):
    x0 = problem.layout.initial()
    jac = (lambda th: problem.jacobian(th)[1]) if sparse else (lambda th: problem.jacobian(th)[1].toarray())
    return least_squares(problem.residual, x0, jac=jac, method="trf", tr_solver="lsmr" if sparse else "exact",
                         xtol=1e-15, ftol=1e-15, gtol=1e-15)


@pytest.mark.parametrize("name", CASES)
def test_zero_residual_problems_match_scipy(name):
    make, root = CASES[name]
    problem = make()
    result = solve_lm(problem)
    assert result.status is Status.CONVERGED, result.reason
    assert result.norm < 1e-10
    ref = _scipy_reference(problem, sparse=name.startswith("broyden"))
    assert np.linalg.norm(ref.fun) < 1e-9
    tol = 1e-4 if name == "powell_singular" else 1e-8  # singular root: both converge only linearly
    np.testing.assert_allclose(result.theta, ref.x, atol=tol)
    if root is not None:
        np.testing.assert_allclose(result.theta, root, atol=tol)


def test_bundle_adjustment_like_matches_scipy_minimum():
    problem = tp.bundle_adjustment_like()
    result = solve_lm(problem)
    assert result.status is Status.STALLED  # a nonzero-residual minimum: LM stops on a vanishing step
    assert "step" in result.reason
    ref = _scipy_reference(problem, sparse=True)
    assert result.norm == pytest.approx(np.linalg.norm(ref.fun), rel=1e-9)
    np.testing.assert_allclose(result.theta, ref.x, atol=1e-6)
    without_schur = solve_lm(problem, LMParams(schur=False))
    np.testing.assert_allclose(without_schur.theta, result.theta, atol=1e-9)
