"""Structured (kron) normal equations of sampled-curve blocks; structured path == general path."""

import numpy as np
import pytest

from legplan.solve import LMParams, Status, StructuredBlock, check_jacobian, check_normal_terms, make_solver, solve_lm
from legplan.solve.schur import SchurSolver
import testproblems as tp


@pytest.fixture(scope="module")
def small():
    return tp.step_planner_like(num_samples=12, degree=4, dim=5, slack_dim=3, num_clearance=4, epsilon=0.05)


def _point(problem, seed=3):
    theta = problem.layout.initial()
    return theta + 0.2 * np.random.default_rng(seed).standard_normal(theta.size)


def test_curve_blocks_have_correct_jacobians_and_normal_terms(small):
    values = small.layout.values(_point(small))
    structured = [b for b in small.blocks if isinstance(b, StructuredBlock)]
    assert len(structured) == 2
    for block in structured:
        assert check_jacobian(block, values).max_abs_error < 1e-7
        assert check_normal_terms(block, values) < 1e-12


def test_structured_and_stacked_paths_give_the_same_step(small):
    theta = _point(small)
    steps = []
    for assembly in ("blocks", "stacked"):
        ne = small.normal_equations(theta, assembly)
        solver = make_solver("cholmod")
        solver.factorize(ne.hessian, 0.1)
        steps.append(solver.solve(ne.gradient))
    np.testing.assert_allclose(steps[0], steps[1], rtol=1e-9, atol=1e-12)
    eliminate, block = small.layout.schur_columns()
    schur = SchurSolver(make_solver("cholmod"), eliminate, block)
    schur.factorize(small.normal_equations(theta).hessian, 0.1)
    np.testing.assert_allclose(schur.solve(small.normal_equations(theta).gradient), steps[0], rtol=1e-8, atol=1e-12)


def test_pattern_survives_inequalities_switching(small):
    versions = {small.normal_equations(_point(small, seed)).pattern_version for seed in range(4)}
    assert len(versions) == 1


def test_step_planner_like_problem_is_solved_to_its_tolerance(small):
    result = solve_lm(small, LMParams(tolerance=1e-9))
    assert result.status is Status.CONVERGED, result.reason
    xi = result.values["xi"]
    assert np.all(np.abs(xi) <= 0.05 + 1e-9)
    assert result.values["P"][:5] == pytest.approx(small.layout.blocks["P"].value[:5])  # fixed start point


def test_schur_path_gives_the_same_lm_iterates_as_the_full_system(small):
    """One eigendecomposition per linearisation + a diagonal rescale per λ (rejected steps) must
    reproduce LM on the full, un-eliminated system: same accept/reject sequence and ‖h‖ history."""
    theta = small.layout.initial()
    start = theta + 3.0 * np.random.default_rng(5).standard_normal(theta.size)  # far out: many rejections
    params = dict(tolerance=1e-9, max_iterations=40)
    full = solve_lm(small, LMParams(schur=False, linear_solver="dense", assembly="stacked", **params), theta0=start)
    fast = solve_lm(small, LMParams(**params), theta0=start)
    assert fast.rejected_steps > 0  # the reuse across a rejected step is exercised
    assert (fast.accepted_steps, fast.rejected_steps) == (full.accepted_steps, full.rejected_steps)
    np.testing.assert_allclose(fast.norm_history, full.norm_history, rtol=1e-8, atol=1e-13)
    np.testing.assert_allclose(fast.lambda_history, full.lambda_history, rtol=1e-12)


def test_trial_norm_is_exact_below_the_bound_and_at_least_the_bound_above(small):
    theta = _point(small, seed=7)
    full = float(np.linalg.norm(small.residual(theta)))
    assert small.trial_norm(theta, np.inf) == pytest.approx(full, rel=1e-13)
    assert small.trial_norm(theta, 1.0001 * full) == pytest.approx(full, rel=1e-13)
    for bound in (0.1 * full, 0.5 * full, 0.9999 * full):
        partial = small.trial_norm(theta, bound)
        assert bound <= partial <= full * (1 + 1e-13)
    assert small.trial_norm(theta, 1e-3 * full) < full  # stopped before the last chunk


def test_early_reject_gives_the_same_lm_iterates(small):
    theta = small.layout.initial()
    start = theta + 3.0 * np.random.default_rng(5).standard_normal(theta.size)
    runs = [solve_lm(small, LMParams(tolerance=1e-9, max_iterations=40, early_reject=flag), theta0=start)
            for flag in (False, True)]
    assert runs[0].rejected_steps > 0
    assert [(r.accepted_steps, r.rejected_steps, r.status) for r in runs[1:]] == \
        [(runs[0].accepted_steps, runs[0].rejected_steps, runs[0].status)]
    np.testing.assert_allclose(runs[1].norm_history, runs[0].norm_history, rtol=1e-12, atol=0)
    np.testing.assert_allclose(runs[1].theta, runs[0].theta, rtol=1e-10, atol=1e-13)
