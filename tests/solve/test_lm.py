"""SolveLM behaviour: Algorithm 1 damping, stop reasons, non-PD handling, solvers, scaling."""

import numpy as np
import pytest

from legplan.solve import (BlockDiagonal, FunctionBlock, LMParams, NormalTerms, Problem, Status, StructuredBlock,
                           VariableBlock, solve_lm)
import testproblems as tp


def test_damping_follows_algorithm_1():
    problem = tp.rosenbrock()
    params = LMParams()
    seen = []
    result = solve_lm(problem, params, callback=lambda it, norm, lam: seen.append((it, norm, lam)))
    assert [s[0] for s in seen] == list(range(1, result.iterations + 1))
    lam = params.lambda_init
    prev = result.initial_norm
    for (_, norm, new_lam) in seen:
        expected = lam * params.lambda_drop if norm < prev else lam * params.lambda_boost
        assert new_lam == pytest.approx(expected)
        assert norm <= prev  # only improving steps are accepted
        lam, prev = new_lam, norm
    assert result.norm_history == [s[1] for s in seen] and result.lambda_history == [s[2] for s in seen]
    assert result.accepted_steps + result.rejected_steps == result.iterations
    assert result.rejected_steps > 0  # Rosenbrock from (−1.2, 1) needs some rejected steps


def test_max_iterations_reason():
    result = solve_lm(tp.rosenbrock(), LMParams(max_iterations=3))
    assert result.status is Status.MAX_ITERATIONS and result.iterations == 3
    assert "MaxIt = 3" in result.reason and not result.success


def test_lambda_too_large_reason():
    result = solve_lm(tp.bundle_adjustment_like(num_poses=3, num_landmarks=10),
                      LMParams(step_tolerance=0.0, lambda_max=1e3, max_iterations=500))
    assert result.status is Status.STALLED and "lambda_max" in result.reason


def test_numerical_failure_on_nan_start():
    problem = Problem([VariableBlock("x", [-1.0])])
    problem.add_residual(FunctionBlock(["x"], 1, lambda x: (np.full(1, np.nan), [np.ones((1, 1))])))
    result = solve_lm(problem)
    assert result.status is Status.NUMERICAL_FAILURE and "not finite" in result.reason


def test_nan_trial_point_is_a_rejected_step():
    # log(x) = 0 from x = 0.05: the undamped first step would leave the domain (x < 0)
    problem = Problem([VariableBlock("x", [0.05])])
    problem.add_residual(FunctionBlock(["x"], 1, lambda x: (np.log(x), [np.diag(1 / x)])))
    with np.errstate(invalid="ignore"):
        result = solve_lm(problem, LMParams(lambda_init=1e-6))
    assert result.status is Status.CONVERGED
    np.testing.assert_allclose(result.values["x"], [1.0])


class _IndefiniteBlock(StructuredBlock):
    """r = x − 1 whose normal terms lie: JᵀJ = −4I (indefinite), so small λ fails to factorise."""

    variables = ("x",)
    size = 3

    def evaluate(self, values, jacobians):
        return values[0] - 1, ([np.eye(3)] if jacobians else None)

    def normal_terms(self, values):
        r = values[0] - 1
        return NormalTerms(r, {(0, 0): BlockDiagonal(-4 * np.eye(3)[None])}, [r])


@pytest.mark.parametrize("solver", ["cholmod", "scipy", "dense"])
def test_non_positive_definite_raises_lambda_instead_of_crashing(solver):
    problem = Problem([VariableBlock("x", np.zeros(3))])
    problem.add_residual(_IndefiniteBlock())
    result = solve_lm(problem, LMParams(linear_solver=solver))
    assert result.rejected_steps >= 4  # λ must grow from 1 past 4 (1.5⁴ > 4)
    assert result.lambda_history[0] == pytest.approx(1.5)
    assert result.status is not Status.NUMERICAL_FAILURE
    assert result.norm < 0.1 * result.initial_norm


@pytest.mark.parametrize("solver", ["cholmod", "scipy", "dense"])
@pytest.mark.parametrize("assembly", ["blocks", "stacked", "jacobian"])
def test_every_solver_and_assembly_gives_the_same_iterates(solver, assembly):
    reference = solve_lm(tp.brown_almost_linear(), LMParams(linear_solver="dense", assembly="stacked"))
    result = solve_lm(tp.brown_almost_linear(), LMParams(linear_solver=solver, assembly=assembly))
    assert result.iterations == reference.iterations
    np.testing.assert_allclose(result.norm_history, reference.norm_history, rtol=1e-6, atol=1e-12)


def test_marquardt_scaling_converges_on_badly_scaled_problem():
    # x0 in metres, x1 in micro-units: r = (x0 − 1, 1e6·x1 − 2, x0·1e6·x1 − 2)
    def fn(x):
        return (np.array([x[0] - 1, 1e6 * x[1] - 2, 1e6 * x[0] * x[1] - 2]),
                [np.array([[1, 0], [0, 1e6], [1e6 * x[1], 1e6 * x[0]]])])
    problem = Problem([VariableBlock("x", [3.0, 0.0])])
    problem.add_residual(FunctionBlock(["x"], 3, fn))
    result = solve_lm(problem, LMParams(marquardt_scaling=True))
    assert result.status is Status.CONVERGED, result.reason
    np.testing.assert_allclose(result.values["x"], [1.0, 2e-6])


def test_timings_are_recorded():
    result = solve_lm(tp.broyden_tridiagonal(200))
    t = result.timings
    assert min(t.evaluate, t.assemble, t.factorize, t.solve) > 0
    assert t.total >= t.evaluate + t.assemble + t.factorize + t.solve


def test_invalid_params():
    with pytest.raises(ValueError):
        LMParams(lambda_drop=2.0)
    with pytest.raises(ValueError):
        LMParams(linear_solver="mkl")



def test_stall_stop_is_off_by_default_and_stops_an_out_of_reach_run():
    # Powell singular converges only linearly (singular Jacobian at the root): 1e-20 is out of reach
    params = dict(max_iterations=60, tolerance=1e-20)
    plain = solve_lm(tp.powell_singular(), LMParams(**params))
    assert plain.status is Status.MAX_ITERATIONS and plain.iterations == 60
    stalled = solve_lm(tp.powell_singular(), LMParams(stall_window=5, **params))
    assert stalled.status is Status.STALLED and "stall_window" in stalled.reason
    assert 5 < stalled.iterations < plain.iterations
    assert stalled.norm_history == plain.norm_history[:stalled.iterations]  # Algorithm 1 iterates up to the stop
    # a fast run is not cut ...
    fast = solve_lm(tp.brown_almost_linear(), LMParams(stall_window=3))
    assert fast.status is Status.CONVERGED and fast.iterations == solve_lm(tp.brown_almost_linear()).iterations
    # ... but a slow phase before fast convergence is (why the stop is opt-in): Rosenbrock's valley
    assert solve_lm(tp.rosenbrock()).status is Status.CONVERGED
    assert solve_lm(tp.rosenbrock(), LMParams(stall_window=10)).status is Status.STALLED
    with pytest.raises(ValueError):
        LMParams(stall_window=-1)


@pytest.mark.parametrize("max_iterations", [3, 100])
def test_no_linearisation_once_the_loop_stops(max_iterations):
    """After the step that meets ε_num, or at MaxIt, LM stops without linearising the new point;
    the norm it reports is ‖h‖ of the accepted trial point."""
    problem = tp.broyden_tridiagonal(200)
    calls = []
    linearize = problem.normal_equations
    problem.normal_equations = lambda theta, assembly: calls.append(1) or linearize(theta, assembly)
    result = solve_lm(problem, LMParams(max_iterations=max_iterations, tolerance=1e-8))
    assert result.rejected_steps == 0
    assert len(calls) == result.accepted_steps == result.iterations
    np.testing.assert_allclose(result.norm, np.linalg.norm(problem.residual(result.theta)), rtol=1e-12)
    assert result.status is (Status.CONVERGED if max_iterations == 100 else Status.MAX_ITERATIONS)


@pytest.mark.parametrize("make", [lambda: tp.broyden_tridiagonal(300), tp.bundle_adjustment_like,
                                  lambda: tp.step_planner_like(num_samples=12, degree=4, dim=5, slack_dim=3,
                                                               num_clearance=4, epsilon=0.05)])
@pytest.mark.parametrize("marquardt", [False, True])
def test_jacobian_assembly_takes_the_steps_of_the_blocks_assembly(make, marquardt):
    """assembly="jacobian" (CHOLMOD factorises JᵀJ + λI from J; with Schur elimination the solver
    forms JᵀJ itself) solves the same eq. (13) as the default path, with or without Marquardt scaling."""
    reference = solve_lm(make(), LMParams(marquardt_scaling=marquardt, tolerance=1e-9))
    result = solve_lm(make(), LMParams(marquardt_scaling=marquardt, tolerance=1e-9, assembly="jacobian"))
    assert (result.status, result.iterations, result.accepted_steps) == \
        (reference.status, reference.iterations, reference.accepted_steps)
    np.testing.assert_allclose(result.norm_history, reference.norm_history, rtol=1e-6, atol=1e-11)
    np.testing.assert_allclose(result.theta, reference.theta, rtol=1e-7, atol=1e-9)


def test_step_norm_is_numpys_vector_norm():
    from legplan.solve.lm import _norm

    v = np.random.default_rng(4).normal(size=1001) * 1e3
    assert _norm(v) == float(np.linalg.norm(v)) and _norm(np.zeros(0)) == 0.0
