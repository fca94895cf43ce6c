"""End-to-end solves of the centroidal problem on small terrains (heuristic initialization)."""

from dataclasses import replace

import numpy as np
import pytest

from legplan.dyn.constraints import GRAVITY
from legplan.dyn.planner import POLISH_RESERVE, Stage, Start, When, plan, schedule
from legplan.dyn.problem import PAPER_COSTS, DynParams, DynTask, build_problem, range_excess_times
from legplan.errors import LegplanError
from legplan.solve import Status

KNOTS_ONLY = DynParams(dynamics_points=1, unloaded_polynomials=None, leg_clearance=None)
"""TOWR's formulation (dynamics at evenly spaced base knots alone, no leg clearance): the planner's
stages, budgets and warm starts are tested on it, fast."""


def _newton_euler_at_knots(result, anymal):
    """m(p̈ + g) − Σf at the base knots, recomputed from the 10 ms samples (the knots are samples)."""
    s = result.samples
    knots = result.problem.form.knots
    idx = np.searchsorted(s["t"], knots - 1e-9)
    lin = anymal.mass * (s["base_acc"][idx] + [0.0, 0.0, GRAVITY]) - s["forces"][idx].sum(axis=1)
    return np.abs(lin).max()


def test_flat_trot_reaches_the_goal_feasibly(anymal, flat):
    r = plan(DynTask((0.0, 0.0, 0.0), (0.6, 0.1, 0.2), "trot", 3, 2.0), anymal, flat, KNOTS_ONLY)
    assert r.success, r.reason
    assert r.solve.max_violation <= 1e-3 and r.solve.iterations <= 30
    s = r.samples
    assert s["base_pos"][-1, :2] == pytest.approx([0.6, 0.1], abs=1e-9)
    assert s["base_euler"][-1] == pytest.approx([0.0, 0.0, 0.2], abs=1e-9)
    assert s["base_vel"][[0, -1]] == pytest.approx(np.zeros((2, 3)), abs=1e-9)
    assert _newton_euler_at_knots(r, anymal) <= 1e-3
    stance = s["contact"]
    assert np.abs(s["forces"][~stance]).max() <= 1e-9  # no force in swing
    assert np.abs(s["feet_pos"][stance][:, 2]).max() <= 1e-3  # stance feet on the ground
    assert s["feet_pos"][:, :, 2].min() >= -1e-3


def test_step_climb_keeps_swing_feet_above_the_step(anymal, step):
    r = plan(DynTask((-0.2, 0.0, 0.0), (0.8, 0.0, 0.0), "trot", 4, 3.0), anymal, step, KNOTS_ONLY)
    assert r.success, r.reason
    feet = r.samples["feet_pos"].reshape(-1, 3)
    clearance = feet[:, 2] - step.height(feet[:, 0], feet[:, 1])
    assert clearance.min() >= -5e-3
    assert r.samples["base_pos"][-1, 2] > 0.1 + 0.3  # ended on top of the step
    stance = r.samples["feet_pos"][r.samples["contact"]]
    assert step.stance_slope(stance[:, 0], stance[:, 1]).max() <= 0.5 + 1e-3  # off the step's edge


def test_infeasible_task_fails_with_a_reason(anymal, flat):
    # 1.5 m in 0.8 s with one stride: far beyond the range of motion
    r = plan(DynTask((0.0, 0.0, 0.0), (1.5, 0.0, 0.0), "walk", 1, 0.8), anymal, flat, KNOTS_ONLY)
    assert not r.success and r.status is not Status.CONVERGED and r.stages[-1].status is r.status
    assert r.solve.max_violation > 1e-3 and r.reason


def test_iteration_budget_caps_every_stage_together(anymal, flat):
    task = DynTask((0.0, 0.0, 0.0), (0.6, 0.1, 0.2), "trot", 3, 2.0)
    params = replace(KNOTS_ONLY, costs=PAPER_COSTS)
    full = plan(task, anymal, flat, params)
    assert full.success and full.solve.iterations > 2, full.reason
    r = plan(task, anymal, flat, replace(params, iteration_budget=full.solve.iterations - 2))
    assert not r.success and r.solve.iterations <= full.solve.iterations - 2
    assert r.status is Status.MAX_ITERATIONS


def test_a_budget_spent_before_the_costs_settle_is_no_solution(anymal, flat):
    """A budget that ends with the feasibility stages leaves the costs unoptimized: the plan is
    feasible but has not converged, and says which stage the budget ran out in (with one iteration
    of costs it is neither: their first step trades the constraints for the costs)."""
    task = DynTask((0.0, 0.0, 0.0), (0.6, 0.1, 0.2), "trot", 3, 2.0)
    params = replace(KNOTS_ONLY, costs=PAPER_COSTS)
    full = plan(task, anymal, flat, params)
    assert full.success and [s.name for s in full.stages][:2] == ["feasibility", "costs"], full.reason
    assert all(s.status is Status.CONVERGED for s in full.stages)
    before_costs = full.stages[0].result.iterations
    for extra in (0, 1):  # the costs stage gets no iteration, or one (not enough to settle)
        r = plan(task, anymal, flat, replace(params, iteration_budget=before_costs + extra))
        assert not r.success, r.reason
        assert extra or r.solve.max_violation <= 1e-3  # feasible all the same
        assert [(s.name, s.status) for s in r.stages] == [("feasibility", Status.CONVERGED),
                                                          ("costs", Status.MAX_ITERATIONS)]


class _Replay:
    """An initializer that hands back a solution of the task itself, as a perfect learned one would."""

    near_solution = True

    def __init__(self, values):
        self.values = values

    def __call__(self, *_):
        return self.values


def test_a_near_solution_guess_is_solved_from_the_guess_without_the_staged_fallback(anymal, step):
    task = DynTask((-0.2, 0.0, 0.0), (0.8, 0.0, 0.0), "trot", 4, 3.0)
    params = replace(KNOTS_ONLY, costs=PAPER_COSTS)
    first = plan(task, anymal, step, params)
    assert first.success, first.reason
    again = plan(task, anymal, step, params, _Replay(first.solve.values))
    assert again.success and [s.name for s in again.stages] in (["direct"], ["direct", "projection after direct"])
    assert again.solve.iterations <= 8 < first.solve.iterations
    assert again.solve.cost <= first.solve.cost * (1 + 1e-2)


def test_a_plan_from_its_own_converged_solution_converges_in_few_iterations():
    """A perfect learned guess (the task's own converged plan) on the planner's model with the paper's
    costs: the costs stage stops once its cost settled and a projection finishes the constraints, to
    the same tolerances, in a few LM iterations (a guess at the solution needs no dozen subproblems to
    creep back within 1e-3 N of the Newton–Euler rows); the plan passes the independent check."""
    from pathlib import Path

    from legplan.dyn.settings import dyn_params
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain import build_map
    from legplan.validate.trajectory import check_trajectory

    robot = load_robot("anymal")
    params = dyn_params("paper")
    model = centroidal_model(robot, params, "paper")
    terrain_map = build_map(Path(__file__).parents[2] / "maps" / "flat.yaml")
    terrain = TerrainModel(terrain_map)
    task = DynTask((0.0, 0.0, 0.0), (0.8, 0.1, 0.2), "trot", 4, 2.4)
    first = plan(task, model, terrain, params)
    assert first.success, first.reason
    again = plan(task, model, terrain, params, _Replay(first.solve.values))
    assert again.success, again.reason
    assert again.solve.iterations <= 8 and again.solve.cost <= first.solve.cost * (1 + 1e-2)
    assert again.solve.max_violation <= params.warm_solver.violation_tolerance
    check = check_trajectory(again.samples, model, terrain_map, robot, node_times=again.problem.form.knots)
    assert check.ok, check.failures()


def test_a_near_solution_guess_is_projected_onto_the_constraints_with_warm_stage_projection(anymal, step):
    """warm_stage "projection": the constraints alone from the guess (one stage, fewer iterations than
    the costs from the same guess), the guess's shape kept, the costs reported at the result."""
    task = DynTask((-0.2, 0.0, 0.0), (0.8, 0.0, 0.0), "trot", 4, 3.0)
    params = replace(KNOTS_ONLY, costs=PAPER_COSTS)
    solved = plan(task, anymal, step, params)
    assert solved.success, solved.reason
    guess = {name: value.copy() for name, value in solved.solve.values.items()}
    guess["forces"] *= 1.05  # off the dynamics by 5 % of the weight: not feasible as given
    guess["base_lin"] += 0.005
    projected = plan(task, anymal, step, replace(params, warm_stage="projection"), _Replay(guess))
    costs = plan(task, anymal, step, params, _Replay(guess))
    assert projected.success and costs.success, (projected.reason, costs.reason)
    assert [s.name for s in projected.stages] == ["projection"] and not projected.problem.costs  # constraints alone
    assert projected.solve.iterations < costs.solve.iterations
    violations = [float(k.violation(np.asarray(k.block.evaluate([projected.solve.values[v] for v in k.block.variables],
                                                                False)[0])).max(initial=0.0))
                  for k in build_problem(task, anymal, step, params, lambda *_: projected.solve.values).constraints]
    assert max(violations) <= 1e-3
    assert np.abs(projected.solve.values["base_lin"] - guess["base_lin"]).max() < 0.05
    assert set(projected.solve.cost_terms) == set(costs.solve.cost_terms)
    assert projected.solve.cost == pytest.approx(sum(projected.solve.cost_terms.values()))
    assert projected.solve.cost >= costs.solve.cost * (1 - 1e-2)  # the costs' optimum is no worse


class _Bounded(_Replay):
    """A replayed guess with the training filter's bound on the cost, as a learned init.h5 has: `bound`
    at the filter's own threshold, each further unit of tolerance adding `threshold`."""

    def __init__(self, values, bound, threshold=0.0):
        super().__init__(values)
        self.bound, self.threshold = bound, threshold

    def cost_bound(self, task, tolerance=1.0):
        return self.bound + (tolerance - 1.0) * self.threshold


def test_warm_stage_polish_optimizes_the_costs_only_of_a_projection_above_the_bound(anymal, step):
    """polish: the projection as it is when its cost is within the bound; above it, the costs then
    the constraints from the projection, kept when converged at a lower cost, the effort of every
    stage counted within the budget."""
    task = DynTask((-0.2, 0.0, 0.0), (0.8, 0.0, 0.0), "trot", 4, 3.0)
    params = replace(KNOTS_ONLY, costs=PAPER_COSTS)
    solved = plan(task, anymal, step, params)
    guess = {name: value.copy() for name, value in solved.solve.values.items()}
    guess["forces"] *= 1.05
    guess["base_lin"] += 0.005
    projected = plan(task, anymal, step, replace(params, warm_stage="projection"), _Replay(guess))
    assert projected.success, projected.reason
    within = plan(task, anymal, step, replace(params, warm_stage="polish"), _Bounded(guess, projected.solve.cost))
    assert [s.name for s in within.stages] == ["projection"] and within.solve.cost == projected.solve.cost
    c = projected.solve.cost
    lenient = plan(task, anymal, step, replace(params, warm_stage="polish", polish_tolerance=2.0),
                   _Bounded(guess, 0.9 * c, 0.2 * c))  # above the filter's bound, within twice its threshold
    assert [s.name for s in lenient.stages] == ["projection"]
    budget = 40
    above = plan(task, anymal, step, replace(params, warm_stage="polish", iteration_budget=budget),
                 _Bounded(guess, 0.5 * projected.solve.cost))
    assert above.success, above.reason
    names = [s.name for s in above.stages]
    assert names[:3] == ["projection", "costs", "projection after costs"] and "projection kept" not in names
    assert above.solve.cost < projected.solve.cost
    assert above.solve.iterations > projected.solve.iterations and above.solve.iterations <= budget
    assert sum(h["iterations"] for h in above.solve.history) == above.solve.iterations
    tight = plan(task, anymal, step, replace(params, warm_stage="polish",
                                             iteration_budget=projected.solve.iterations + 1),
                 _Bounded(guess, 0.5 * projected.solve.cost))  # one iteration of costs: not converged
    assert tight.success and [s.name for s in tight.stages][:4] == ["projection", "costs", "projection after costs",
                                                                   "projection kept"]
    assert tight.solve.cost == pytest.approx(projected.solve.cost)
    assert np.array_equal(tight.solve.values["base_lin"], projected.solve.values["base_lin"])
    assert tight.solve.iterations == projected.solve.iterations + 1
    reserved = replace(params, warm_stage="polish", iteration_budget=projected.solve.iterations + 2 + POLISH_RESERVE)
    kept = plan(task, anymal, step, reserved, _Bounded(guess, 0.5 * projected.solve.cost))
    spent = {name: sum(s.result.iterations for s in kept.stages if s.name == name)
             for name in ("costs", "projection after costs")}
    assert spent["costs"] <= 2 and spent["projection after costs"] >= 1  # the costs leave the last projection its share


def test_the_schedule_is_declared_as_data():
    """Without a near-solution guess: feasibility, then with costs the costs and a projection back,
    the same with TOWR's swing constraint switched, then the range refinements; from one: first the
    costs, stopped once settled, and a projection after them if that left rows out, or the projection
    and with "polish" its polishing stages."""
    plain = schedule(DynParams())
    assert [s.name for s in plain] == ["feasibility", "feasibility (with TOWR's swing constraint)",
                                       "without TOWR's swing constraint (with TOWR's swing constraint)",
                                       "range of motion", "range of motion", "range of motion"]
    assert [s.when for s in plain[:3]] == [When.START, When.START, When.FAILED]
    assert [s.towr_swing for s in plain[:3]] == [False, True, False] and plain[0].start is Start.GUESS
    costs = replace(DynParams(), costs=PAPER_COSTS)
    assert [(s.name, s.costs, s.solver) for s in schedule(costs)[:3]] == [
        ("feasibility", False, "solver"), ("costs", True, "cost_solver"), ("feasibility after costs", False, "solver")]
    assert schedule(costs, near_solution=True)[:2] == [
        Stage("direct", True, "warm_solver", When.START, Start.NEAR_GUESS, settled_exit=True),
        Stage("projection after direct", False, "projection_solver", When.FAILED)]
    polish = schedule(replace(costs, warm_stage="polish"), near_solution=True)
    assert [(s.name, s.when) for s in polish[:3]] == [("projection", When.START), ("costs", When.ABOVE_BOUND),
                                                      ("projection after costs", When.AFTER)]
    assert polish[1].reserve == POLISH_RESERVE and polish[2].keeps_better
    assert schedule(DynParams(), near_solution=True) == plain  # no costs, warm stage "costs": nothing to do first


def test_warm_stage_is_costs_or_projection():
    with pytest.raises(LegplanError, match="warm_stage"):
        DynParams(warm_stage="feasibility")
    for bad in (-0.5, float("nan")):
        with pytest.raises(LegplanError, match="polish_tolerance"):
            DynParams(polish_tolerance=bad)


def _range_excess(result, anymal) -> float:
    """Largest excess (m) of any foot over its range-of-motion box on a 1 ms grid, recomputed with
    scipy's rotation (roll, pitch, yaw as extrinsic x, y, z) from the sampled solution."""
    from scipy.spatial.transform import Rotation

    from legplan.dyn.planner import sample_solution

    s = sample_solution(result.problem.form, result.solve.values, 0.001)
    rot = Rotation.from_euler("xyz", s["base_euler"]).as_matrix()
    offset = np.einsum("nji,nlj->nli", rot, s["feet_pos"] - s["base_pos"][:, None]) - anymal.nominal_feet
    return float((np.abs(offset) - anymal.range_of_motion).max())


def test_feet_stay_in_their_range_of_motion_between_the_samples(anymal, flat, monkeypatch):
    import legplan.dyn.planner as planner

    task = DynTask((0.0, 0.0, 0.0), (1.5, 0.0, 0.0), "walk", 4, 3.5)
    params = replace(KNOTS_ONLY, range_margin=0.0)  # the box itself at the samples, no margin for between
    refined = plan(task, anymal, flat, params)
    assert refined.success, refined.reason
    assert _range_excess(refined, anymal) <= 1e-6  # on the box's boundary at most (the solver's tolerance)
    monkeypatch.setattr(planner, "RANGE_ROUNDS", 0)  # samples every 0.04 s only: a foot leaves the box between
    sampled = plan(task, anymal, flat, params)
    assert sampled.success and _range_excess(sampled, anymal) > 1e-4


def test_a_near_solution_guess_is_sampled_where_it_comes_near_its_range_of_motion(anymal, flat, monkeypatch):
    """From a guess whose feet leave their boxes between the regular samples (a plan solved without
    the range margin or its refinement, nudged off the dynamics), the projection samples the range
    there from the start: no refinement round, no foot out of its box."""
    import legplan.dyn.planner as planner

    task = DynTask((0.0, 0.0, 0.0), (1.5, 0.0, 0.0), "walk", 4, 3.5)
    with monkeypatch.context() as unrefined:
        unrefined.setattr(planner, "RANGE_ROUNDS", 0)
        sampled = plan(task, anymal, flat, replace(KNOTS_ONLY, range_margin=0.0))
    assert sampled.success and _range_excess(sampled, anymal) > 1e-4
    guess = {name: value.copy() for name, value in sampled.solve.values.items()}
    guess["forces"] *= 1.05
    params = replace(KNOTS_ONLY, warm_stage="projection")
    projected = plan(task, anymal, flat, params, _Replay(guess))
    assert projected.success and [s.name for s in projected.stages] == ["projection"], projected.reason
    assert projected.problem.range_times.size and _range_excess(projected, anymal) <= 1e-6
    near = range_excess_times(projected.problem, guess, -planner.GUESS_RANGE_NEAR)
    assert np.array_equal(projected.problem.range_times, near)
    assert near.size > range_excess_times(projected.problem, guess).size  # also where inside, within 5 mm


def test_range_refinement_of_a_plan_with_costs_keeps_its_cost_terms(anymal, flat):
    """The refinement solves the constraints alone; the plan still reports its costs' terms, evaluated
    at the final values by blocks built apart from the planner's."""
    from legplan.dyn.costs import integral_costs

    task = DynTask((0.0, 0.0, 0.0), (1.5, 0.0, 0.0), "walk", 4, 3.5)
    result = plan(task, anymal, flat, replace(KNOTS_ONLY, costs=PAPER_COSTS))
    assert result.success, result.reason
    assert result.stages[-1].name == "range of motion"  # the last stage was a refinement
    assert _range_excess(result, anymal) <= 1e-9
    expected = {t.name: 0.5 * t.weight * float(np.sum(t.block.evaluate([result.solve.values[v] for v in t.block.variables],
                                                                       False)[0] ** 2))
                for t in integral_costs(result.problem.form, PAPER_COSTS, anymal.mass)}
    for name, value in expected.items():
        assert result.solve.cost_terms[name] == pytest.approx(value, rel=1e-9)
    assert result.solve.cost == pytest.approx(sum(result.solve.cost_terms.values()), rel=1e-12)
    assert result.solve.cost > 0.0


def test_optimized_phase_durations_give_a_checked_plan_on_their_own_timing(anymal, flat):
    """optimize_phases: the flat trot converges with durations of its own (at least `phase_min`
    each, the last of every foot included, summing to T), the plan is sampled on that timing (contact
    flags from the optimized durations, no force off contact) and passes the independent check."""
    from legplan.dyn.gait import make_gait
    from legplan.dyn.timing import PHASES
    from legplan.robots import load_robot
    from legplan.terrain import Grid2D, terrain_from_heightmap
    from legplan.validate.trajectory import CheckTolerances, check_trajectory

    task = DynTask((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "trot", 4, 2.4)
    params = replace(KNOTS_ONLY, optimize_phases=True)
    r = plan(task, anymal, flat, params)
    assert r.success, r.reason
    form, timing = r.problem.form, r.problem.timing
    gait = make_gait("trot", 4, 2.4)
    durations = form.gait.durations
    assert durations.sum() == pytest.approx(2.4, abs=1e-9)
    assert not (durations.shape == gait.durations.shape and np.allclose(durations, gait.durations, atol=1e-6))
    d = r.solve.values[PHASES]
    assert d.size == 2 * gait.footsteps == timing.size
    assert d.min() >= params.phase_min - 1e-9
    last = np.array([task.duration - timing.leg_durations(d, leg).sum() for leg in range(form.legs)])
    assert last.min() >= params.phase_min - 1e-3

    s = r.samples
    t = s["t"]
    assert np.diff(t)[:-1] == pytest.approx(np.full(t.size - 2, 0.01))
    np.testing.assert_array_equal(s["contact"], form.gait.contact(t))
    for leg in range(form.legs):  # the flags again from the durations alone: stance, swing, ..., stance
        bounds = np.concatenate([[0.0], np.cumsum(timing.leg_durations(d, leg))])
        phase = np.searchsorted(bounds, t, side="right") - 1
        away = np.abs(t[:, None] - bounds[None, 1:]).min(axis=1) > 1e-9
        np.testing.assert_array_equal(s["contact"][away, leg], phase[away] % 2 == 0)
    assert not np.array_equal(s["contact"], gait.contact(t))  # not the gait's timing
    swing = ~s["contact"]
    assert swing.any() and np.linalg.norm(s["forces"][swing], axis=-1).max() < 1e-6

    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))  # the `flat` fixture's map
    terrain_map = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    # made with KNOTS_ONLY: the residual between the knots is not the planner's to keep; by TOWR's scalar
    # model (the fixture): the joint torques are not either (tests/validate judges them); the rest is judged
    check = check_trajectory(s, anymal, terrain_map, load_robot("anymal"), CheckTolerances(between=np.inf, torque=np.inf),
                             node_times=form.knots)
    assert check.ok, {name: check.worst[name] for name, ok in check.passed.items() if not ok}
    assert _newton_euler_at_knots(r, anymal) <= 1e-3


def test_leg_clearance_keeps_thigh_and_shank_off_the_step_by_an_independent_check(anymal):
    """A trot onto a 10 cm step: with `leg_clearance` 5 cm the legs' spheres, placed by pinocchio FK
    of the numerical IK (the validator, not the planner's closed form), clear the exact column
    terrain by over 4 cm; without it the plan takes a shank within 2 cm of the step. (Dynamics at
    the knots only: the between-knot bound is not judged.)"""
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain import Grid2D, terrain_from_heightmap
    from legplan.validate.trajectory import CheckTolerances, check_trajectory

    robot = load_robot("anymal")
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))
    x, _ = grid.centres()
    terrain_map = terrain_from_heightmap(0.1 * np.clip((x - 0.46) / 0.04, 0.0, 1.0), grid, name="step")
    terrain = TerrainModel(terrain_map)
    task = DynTask((-0.2, 0.0, 0.0), (1.0, 0.0, 0.0), "trot", 4, 3.0)
    depth = {}
    for clearance in (None, 0.05):
        result = plan(task, anymal, terrain, replace(KNOTS_ONLY, leg_clearance=clearance))
        assert result.success, result.reason
        # TOWR's scalar model (the fixture) keeps no joint torques: judged elsewhere (tests/validate)
        check = check_trajectory(result.samples, anymal, terrain_map, robot, CheckTolerances(between=np.inf, torque=np.inf),
                                 node_times=result.problem.form.knots)
        assert check.ok, check.worst
        depth[clearance] = check.worst["leg_penetration"]
    assert depth[0.05] < -0.04 and depth[None] > -0.02


def test_flat_trot_keeps_newton_euler_within_5_percent_of_its_weight_at_every_10ms_sample(anymal, flat):
    """The defaults' flying trot (short base polynomials in its support pairs, `unloaded_phases`):
    the independent check finds the Newton–Euler residual at every 10 ms sample, between the knots
    included, within 5 % of m·g (force) and of m·g·ℓ (torque); TOWR's evenly spaced knots under the
    same band cannot reach it (the solver stops infeasible)."""
    from legplan.robots import load_robot
    from legplan.terrain import Grid2D, terrain_from_heightmap
    from legplan.validate.trajectory import CheckTolerances, check_trajectory

    task = DynTask((0.0, 0.0, 0.0), (1.0, 0.0, 0.0), "trot", 4, 2.4)
    r = plan(task, anymal, flat, DynParams())
    assert r.success, r.reason
    assert CheckTolerances().between == 0.05
    grid = Grid2D(origin=(-1.5, -1.0), resolution=0.02, shape=(101, 176))  # the `flat` fixture's map
    terrain_map = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    # TOWR's scalar model (the fixture) keeps no joint torques: judged elsewhere (tests/validate)
    check = check_trajectory(r.samples, anymal, terrain_map, load_robot("anymal"), CheckTolerances(torque=np.inf),
                             node_times=r.problem.form.knots)
    assert check.ok, check.failures()
    weight = anymal.mass * GRAVITY
    assert check.worst["newton_euler_force"] <= 0.05 * weight
    assert check.worst["newton_euler_torque"] <= check.tolerance["newton_euler_torque"]
    even = plan(task, anymal, flat, replace(DynParams(), unloaded_polynomials=None))
    assert even.status is Status.STALLED


def test_the_solver_on_the_jacobians_entries_ever_nonzero_plans_what_the_whole_pattern_plans(anymal, step,
                                                                                              monkeypatch):
    """The hinged LM factorizes `Problem.nonzero_jacobian` (the entries zero by construction left
    out); with the whole structural pattern the plan takes the same iterations and differs by
    round-off only: every variable within 1e-6 of its own size (the fill-reducing order changes)."""
    import scipy.sparse as sp

    from legplan.solve.problem import Problem

    task = DynTask((-0.2, 0.0, 0.0), (0.8, 0.0, 0.0), "trot", 4, 3.0)  # the dynamics between the knots on
    reduced = plan(task, anymal, step, DynParams(leg_clearance=None))
    monkeypatch.setattr(Problem, "nonzero_jacobian",
                        lambda self, theta: (lambda hj: (hj[0], sp.csr_matrix(hj[1])))(self.jacobian(theta)))
    whole = plan(task, anymal, step, DynParams(leg_clearance=None))
    assert reduced.success and whole.success
    assert reduced.solve.iterations == whole.solve.iterations
    for name, value in whole.solve.values.items():
        assert reduced.solve.values[name] == pytest.approx(value, rel=1e-6, abs=1e-6 * np.abs(value).max()), name


def test_swing_feet_clear_stair_edges_at_the_samples_the_check_judges():
    """The bench's stairs walk (8 s, 6 strides: swings that start between the 10 ms samples): with
    fixed phases the swing feet are held above the terrain at the plan's own 10 ms samples too
    (`problem._grid_times`, exactly the times `sample_solution` writes), so the plan passes the
    independent check's exact column distance at the stair edges (without them a right front foot
    crossed a riser 5.7 mm deep between the swing's own samples)."""
    from pathlib import Path

    from legplan.dyn.planner import sample_solution
    from legplan.dyn.problem import SAMPLE_DT, _grid_times
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain import build_map
    from legplan.validate.trajectory import check_trajectory

    robot = load_robot("anymal")
    model = centroidal_model(robot, DynParams())
    terrain_map = build_map(Path(__file__).parents[2] / "maps" / "stairs.yaml")
    result = plan(DynTask((-0.8, 0.0, 0.0), (1.7, 0.0, 0.0), "walk", 6, 8.0), model, TerrainModel(terrain_map),
                  DynParams())
    assert result.success, result.reason
    written = sample_solution(result.problem.form, result.solve.values)["t"]
    for foot in result.problem.form.feet:
        grid = _grid_times(foot, SAMPLE_DT)
        assert grid.size and np.isin(grid, written).all()   # the very floats the artefact holds
        for p in (p for p in foot.phases if not p.stance):
            inside = written[(written > p.t0 + 1e-9) & (written < p.t0 + p.duration - 1e-9)]
            assert np.isin(inside, grid).all()
    check = check_trajectory(result.samples, model, terrain_map, robot, node_times=result.problem.form.knots)
    assert check.passed["penetration_column"] and check.passed["penetration_height"], check.worst
    assert check.ok, check.failures()


def test_a_slow_trot_through_four_leg_hand_overs_plans_and_passes_its_check():
    """The flat-trot task space's 3.5 s trot on the planner's model: its 0.35 s pairs exceed
    `DynParams.line_support`, so they hand over through four-leg support, and its knots sit at the
    pairs' switches (`formulation.pair_switches`); with TOWR's even knots the Newton–Euler rows at the
    knots stalled about 7 N off on every task of the space."""
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain import build_map
    from pathlib import Path
    from legplan.validate.trajectory import check_trajectory

    robot = load_robot("anymal")
    model = centroidal_model(robot, DynParams())
    terrain_map = build_map(Path(__file__).parents[2] / "maps" / "flat.yaml")
    result = plan(DynTask((-0.63, -0.35, -0.48), (0.0, 0.0, 0.0), "trot", 4, 3.5), model, TerrainModel(terrain_map),
                  DynParams())
    assert result.success, result.reason
    assert (result.problem.form.gait.stance.sum(axis=1) == 4).sum() > 2   # the pairs were cut
    check = check_trajectory(result.samples, model, terrain_map, robot, node_times=result.problem.form.knots)
    assert check.ok, check.failures()


def test_a_projection_from_near_a_solution_converges_in_few_steps(anymal, flat):
    """A plan's solution with its forces off by 0.3 % (over a newton of ANYmal's weight on the
    Newton-Euler rows, whose tolerance is 1e-3 N) projects back within three LM steps (one subproblem),
    as Gauss-Newton does from near a feasible point: after each step the model predicted, λ falls fast
    (`ACCURATE_MODEL_DECREASE`) instead of keeping every step damped along J's small singular values."""
    params = DynParams()
    task = DynTask((0.0, 0.0, 0.0), (0.6, 0.1, 0.2), "trot", 3, 2.0)
    solved = plan(task, anymal, flat, params)
    assert solved.success, solved.reason
    guess = {name: value.copy() for name, value in solved.solve.values.items()}
    guess["forces"] *= 1.003
    projected = plan(task, anymal, flat, replace(params, warm_stage="projection"), _Replay(guess))
    assert [s.name for s in projected.stages] == ["projection"] and projected.success, projected.reason
    assert projected.solve.iterations <= 3, projected.solve.history
    assert projected.stages[0].result.history[0]["iterations"] == projected.solve.iterations  # one subproblem
