"""The reference problems' analytic Jacobians agree with central differences."""

import numpy as np
import pytest

from legplan.solve import check_jacobian
import testproblems as tp


@pytest.mark.parametrize("make", [tp.rosenbrock, tp.powell_singular, tp.brown_almost_linear,
                                  lambda: tp.broyden_tridiagonal(1), lambda: tp.broyden_tridiagonal(2),
                                  lambda: tp.broyden_tridiagonal(9),
                                  lambda: tp.bundle_adjustment_like(num_poses=3, num_landmarks=4)])
def test_jacobians_match_finite_differences(make):
    problem = make()
    rng = np.random.default_rng(3)
    values = {name: b.value + 0.3 * rng.standard_normal(b.size) for name, b in problem.layout.blocks.items()}
    for block in problem.blocks:
        for _ in range(2):  # a second evaluation refreshes the values of a reused pattern
            report = check_jacobian(block, values)
            assert report.max_abs_error < 1e-7, report
            values = {name: v + 0.1 for name, v in values.items()}
