"""PlanStep (Algorithm 1) on the toy robot: convergence, violations on dense re-sampling, failures."""

import numpy as np
import pytest

from toy import toy_configuration
from legplan.errors import LegplanError
from legplan.geometry.bezier import evaluate
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import path_vectors, plan_step, unwrap_rotation_vector


def test_body_shift_is_solved_by_the_line(toy_robot, flat_feet, swing_over_hill):
    hill = swing_over_hill[0]
    q0 = toy_configuration([0.0, 0.0, 0.3], flat_feet)
    q1 = toy_configuration([-0.05, -0.03, 0.28], flat_feet)
    plan = plan_step(toy_robot, hill, q0, q1, np.ones(4, bool), flat_feet)
    assert plan.success and plan.degree == 1
    assert [d.iterations for d in plan.degrees] == [0]


def test_swing_over_hill_converges_and_holds_on_dense_samples(toy_robot, swing_over_hill):
    hill, q0, q1, stance, feet = swing_over_hill
    params = StepPlanParams(samples=40)
    plan = plan_step(toy_robot, hill, q0, q1, stance, feet, params)
    assert plan.success, plan.reason
    assert plan.degree >= 2  # the line drives the swing foot through the hill
    assert plan.norm <= params.eps_num
    P = plan.control_points
    assert np.allclose(P[0], q0) and np.allclose(P[-1], q1)
    Q = toy_robot.from_vector(evaluate(P, np.linspace(0, 1, 1001)))
    foot = toy_robot.foot_positions(Q)
    slip = np.linalg.norm(foot[:, stance] - feet[stance], axis=2).max()
    assert slip <= 1.05 * params.epsilon
    swing = foot[:, 0]
    assert np.all(swing[:, 2] - hill.bump(swing[:, :2]) >= -1e-4)  # foot clears the hill
    straight = evaluate(np.stack([q0, q1]), np.linspace(0, 1, 101))
    assert np.any(toy_robot.foot_positions(straight)[:, 0, 2] < hill.bump(np.array([[0.3, 0.15]]))[0] - 0.01)


def test_dense_and_sparse_factorisations_of_the_reduced_system_plan_the_same_step(toy_robot, swing_over_hill):
    """The default linear solver (LAPACK Cholesky of the Schur-reduced system) changes rounding only:
    the same degrees, LM iterations and outcome as CHOLMOD, control points within 1e-9."""
    hill, q0, q1, stance, feet = swing_over_hill
    plans = {solver: plan_step(toy_robot, hill, q0, q1, stance, feet,
                               StepPlanParams(samples=40, linear_solver=solver)) for solver in ("dense", "cholmod")}
    assert StepPlanParams().linear_solver == "dense"
    dense, sparse = plans["dense"], plans["cholmod"]
    assert dense.success and sparse.success and dense.degree == sparse.degree >= 2
    assert [d.iterations for d in dense.degrees] == [d.iterations for d in sparse.degrees]
    assert np.abs(dense.control_points - sparse.control_points).max() <= 1e-9


def test_failure_is_reported_with_reason(toy_robot, swing_over_hill):
    hill, q0, q1, stance, feet = swing_over_hill
    plan = plan_step(toy_robot, hill, q0, q1, stance, feet, StepPlanParams(samples=20, max_degree=1))
    assert not plan.success
    assert "d_max = 1" in plan.reason and plan.norm > 0


def test_rotation_vector_unwrap():
    axis = np.array([0.0, 0.0, 1.0])
    w = unwrap_rotation_vector(-0.9 * np.pi * axis, 0.95 * np.pi * axis)
    assert np.allclose(w, 1.1 * np.pi * axis)
    assert np.allclose(unwrap_rotation_vector(0.1 * axis, 0.2 * axis), 0.1 * axis)


def test_path_vectors_keep_end_configurations(toy_robot, swing_over_hill):
    _, q0, q1, _, _ = swing_over_hill
    x0, x1 = path_vectors(toy_robot, q0, q1)
    assert np.allclose(toy_robot.from_vector(np.stack([x0, x1])), np.stack([q0, q1]))


def test_params_overrides():
    p = StepPlanParams.from_overrides({"samples": "50", "epsilon": "5e-4", "linear_solver": "dense"})
    assert (p.samples, p.epsilon, p.linear_solver) == (50, 5e-4, "dense")
    assert StepPlanParams().as_dict()["max_degree"] == 10
    with pytest.raises(LegplanError, match="step planner parameters: field 'nope' is unknown"):
        StepPlanParams.from_overrides({"nope": "1"})
    with pytest.raises(LegplanError, match="field 'samples' must be a finite number, got 'many'"):
        StepPlanParams.from_overrides({"samples": "many"})
    with pytest.raises(LegplanError, match="field 'epsilon' must be > 0, got '-1'"):
        StepPlanParams.from_overrides({"epsilon": "-1"})


def test_stall_window_is_passed_to_solve_lm_and_off_by_default(toy_robot, swing_over_hill, monkeypatch):
    """`--param stall_window=W` reaches SolveLM (opt-in departure from Algorithm 1); default 0 = off."""
    import legplan.stepplan.planner as planner

    seen = []
    real = planner.solve_lm
    monkeypatch.setattr(planner, "solve_lm", lambda problem, lm: seen.append(lm.stall_window) or real(problem, lm))
    hill, q0, q1, stance, feet = swing_over_hill
    assert StepPlanParams().stall_window == 0
    plan = plan_step(toy_robot, hill, q0, q1, stance, feet,
                     StepPlanParams.from_overrides({"samples": "20", "stall_window": "10"}))
    assert seen and set(seen) == {10}
    assert plan.degree >= 2 and np.isfinite(plan.norm)
    with pytest.raises(LegplanError):
        StepPlanParams(stall_window=-1)


def test_schur_parts_path_plans_the_step_of_the_assembled_system_bit_for_bit(toy_robot, swing_over_hill, monkeypatch):
    """SolveLM takes the planner's normal equations as dense Schur pieces (`Problem.normal_equations` with
    `schur`): the same control points, norms, degrees and LM iterations as through the assembled sparse H."""
    from legplan.solve import Problem

    hill, q0, q1, stance, feet = swing_over_hill
    params = StepPlanParams(samples=40)
    direct = plan_step(toy_robot, hill, q0, q1, stance, feet, params)
    monkeypatch.setattr(Problem, "schur_parts_plan", lambda self, eliminate, block: None)
    assembled = plan_step(toy_robot, hill, q0, q1, stance, feet, params)
    assert direct.success and direct.degree >= 2
    assert np.array_equal(direct.control_points, assembled.control_points) and direct.norm == assembled.norm
    assert [(d.degree, d.iterations, d.norm, d.status) for d in direct.degrees] == \
        [(d.degree, d.iterations, d.norm, d.status) for d in assembled.degrees]
