"""Structured (kron) normal equations of sampled-curve blocks; structured path == general path."""

import numpy as np
import pytest

from legplan.solve import (LMParams, Problem, Status, StructuredBlock, check_jacobian, check_normal_terms, make_solver,
                           solve_lm)
from legplan.geometry.bezier import bernstein_matrix
from legplan.solve import VariableBlock
from legplan.solve.curve import SampledCurveBlock
from legplan.solve.inequality import hinge
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


class _SlackedHinges(SampledCurveBlock):
    """One block with every kind of row of eq. (12) per sample: sin(A q) − f* − ξ (slacked equalities), a
    penalty 2ξ on the slacks and hinges max(sin(C (q − q*)) − ½, 0) (the step planner's shape)."""

    def __init__(self, basis, A, C, target):
        m, c = A.shape[0], C.shape[0]
        super().__init__(("P", "xi"), basis, A.shape[1], 2 * m + c, slack_dim=m)
        self.A, self.C, self.target, self.f_target = A, C, target, np.sin(target @ A.T)

    def sample(self, q, xi, jacobians, index):
        u, v = q @ self.A.T, (q - self.target[index]) @ self.C.T
        hinged, slope = hinge(np.sin(v) - 0.5)
        r = np.concatenate([np.sin(u) - self.f_target[index] - xi, 2.0 * xi, hinged], axis=1)
        if not jacobians:
            return r, None, None
        n, m = xi.shape
        G = np.concatenate([np.cos(u)[:, :, None] * self.A, np.zeros((n, m, self.dim)),
                            (slope * np.cos(v))[:, :, None] * self.C], axis=1)
        S = np.concatenate([np.broadcast_to(-np.eye(m), (n, m, m)), np.broadcast_to(2.0 * np.eye(m), (n, m, m)),
                            np.zeros((n, self.C.shape[0], m))], axis=1)
        return r, G, S


@pytest.fixture(scope="module")
def one_block():
    """The step planner's shape: one structured block over the control points (ends fixed) and the slacks."""
    rng = np.random.default_rng(1)
    samples, degree, dim, m, c = 12, 4, 5, 3, 4
    basis = bernstein_matrix(degree, np.linspace(0.0, 1.0, samples))
    ends = rng.uniform(-1, 1, (2, dim))
    line = ends[0] + np.linspace(0.0, 1.0, degree + 1)[:, None] * (ends[1] - ends[0])
    target = basis @ (line + 0.6 * rng.standard_normal(line.shape) * np.r_[0, np.ones(degree - 1), 0][:, None])
    fixed = np.zeros(line.shape, bool)
    fixed[[0, -1]] = True
    problem = Problem([VariableBlock("P", line.ravel(), fixed=fixed.ravel()),
                       VariableBlock("xi", np.zeros(samples * m), schur_block=m)])
    problem.add_residual(_SlackedHinges(basis, 2.0 * rng.standard_normal((m, dim)), rng.standard_normal((c, dim)),
                                        target))
    return problem


def test_one_block_fixture_has_correct_jacobians_and_normal_terms(one_block):
    values = one_block.layout.values(_point(one_block))
    assert check_jacobian(one_block.blocks[0], values).max_abs_error < 1e-7
    assert check_normal_terms(one_block.blocks[0], values) < 1e-12


def test_schur_parts_are_the_entries_of_the_assembled_normal_matrix(one_block):
    theta = _point(one_block)
    eliminate, block = one_block.layout.schur_columns()
    direct = one_block.normal_equations(theta, schur=(eliminate, block))
    assembled = one_block.normal_equations(theta)
    assert direct.hessian is None and assembled.schur_parts is None
    H = assembled.hessian.toarray()
    keep = np.setdiff1d(np.arange(H.shape[0]), eliminate)
    parts = direct.schur_parts
    assert np.array_equal(parts.kept, H[np.ix_(keep, keep)])
    assert np.array_equal(parts.coupling, H[np.ix_(keep, eliminate)])
    count = eliminate.size // block
    blocks = np.stack([H[np.ix_(eliminate[i * block:(i + 1) * block], eliminate[i * block:(i + 1) * block])]
                       for i in range(count)])
    assert np.array_equal(parts.blocks, blocks)
    assert np.array_equal(direct.gradient, assembled.gradient)
    assert np.array_equal(direct.residual, assembled.residual)
    for beta in (1e-3, 0.5):  # the solver's steps from the pieces and from H: the same bits
        steps = []
        for load in (lambda s: s.set_parts(parts), lambda s: s.set_matrix(assembled.hessian)):
            solver = SchurSolver(make_solver("dense"), eliminate, block)
            load(solver)
            solver.refactor(beta)
            steps.append(solver.solve(assembled.gradient))
        assert np.array_equal(steps[0], steps[1])


def test_schur_parts_only_for_one_structured_block_over_a_kept_and_an_eliminated_variable(small, one_block):
    eliminate, block = small.layout.schur_columns()
    assert small.schur_parts_plan(eliminate, block) is None  # two structured blocks (and a function block)
    assert small.normal_equations(_point(small), schur=(eliminate, block)).schur_parts is None
    assert one_block.schur_parts_plan(eliminate, block) is not None
    assert one_block.schur_parts_plan(eliminate[:-block], block) is None  # not the eliminated variable


def test_lm_from_the_schur_parts_takes_the_steps_of_the_assembled_system(one_block, monkeypatch):
    """LM with H handed over as Schur pieces repeats LM on the assembled H bit for bit: same iterates,
    same ‖h‖ and λ histories, same end point."""
    theta = one_block.layout.initial()
    start = theta + 3.0 * np.random.default_rng(5).standard_normal(theta.size)  # far out: many rejections
    params = LMParams(tolerance=1e-12, max_iterations=60, linear_solver="dense", lambda_init=1e-4)
    calls = []
    original = SchurSolver.set_parts
    monkeypatch.setattr(SchurSolver, "set_parts", lambda self, parts: calls.append(1) or original(self, parts))
    direct = solve_lm(one_block, params, theta0=start)
    assert calls  # the pieces' path was taken
    monkeypatch.setattr(Problem, "schur_parts_plan", lambda self, eliminate, block: None)
    assembled = solve_lm(one_block, params, theta0=start)
    assert direct.rejected_steps > 0 and direct.accepted_steps > 0
    assert direct.norm_history == assembled.norm_history and direct.lambda_history == assembled.lambda_history
    assert np.array_equal(direct.theta, assembled.theta) and direct.status is assembled.status
