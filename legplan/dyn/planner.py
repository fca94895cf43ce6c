"""Plan one centroidal trajectory: build the problem, solve it, sample the solution every 10 ms.

    result = plan(DynTask(start=(0, 0, 0), goal=(1, 0, 0), gait="trot", strides=4, duration=2.4),
                  model, TerrainModel(load_map("map.h5")), DynParams())
    result.success, result.reason, result.samples["base_pos"]

The solver is `legplan.solve.solve_augmented_lagrangian` (augmented Lagrangian over
Levenberg-Marquardt/CHOLMOD; the module docstring there says why and when it stops).
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from legplan.dyn.euler import rotation, world_rates
from legplan.dyn.costs import CostWeights
from legplan.dyn.formulation import Formulation
from legplan.dyn.init import heuristic
from legplan.dyn.problem import DynParams, DynTask, Problem, build_problem, cost_blocks, range_excess_times
from legplan.dyn.terrain import TerrainModel
from legplan.dyn.timing import PHASES
from legplan.solve.auglag import ALParams, ALResult, evaluate_costs, solve_augmented_lagrangian
from legplan.solve.lm import Timings

SAMPLE_DT = 0.01  # s, the artefact's sampling of the solution


@dataclass
class PlanResult:
    """The problem, the solver's outcome and the solution sampled every `SAMPLE_DT`."""

    problem: Problem
    solve: ALResult
    samples: dict[str, np.ndarray]
    setup_seconds: float

    @property
    def success(self) -> bool:
        return self.solve.success

    @property
    def reason(self) -> str:
        return self.solve.reason


def plan(task: DynTask, model, terrain: TerrainModel, params: DynParams = DynParams(), initializer=heuristic,
         callback=None) -> PlanResult:
    """Build, solve and sample one task.

    From a guess that solves a nearby task (an initializer with ``near_solution`` true: the learned
    one) `direct` solves the whole problem, costs included, from the guess in one stage (Algorithm
    1's A_θ: few iterations when the guess is good), or with `DynParams.warm_stage` "projection"
    the constraints alone. Otherwise, or when that fails,
    `attempt` (the constraints, then the costs) from the initializer; if that fails too, `attempt`
    once more with TOWR's swing constraint switched (`DynParams.towr_swing`): of the bench cases and the tests, some
    stall only with it and some only without (measured). A successful plan then goes through
    `refine_range` (feet inside their boxes between the constraint's samples too, by the constraints
    alone); the cost terms reported are those of `params.costs` at the final plan.
    `DynParams.iteration_budget` caps the LM iterations of all of it together. Effort adds up; the
    reason names every stage that ran."""
    budget = Budget(params.iteration_budget)
    stages, setup = [], 0.0
    if getattr(initializer, "near_solution", False) and (params.costs.active or params.warm_stage != "costs"):
        problem, stages, setup = direct(task, model, terrain, params, initializer, budget, callback)
    for switched in (False, True):
        if stages and (stages[-1][1].success or budget.spent):
            break
        run = replace(params, towr_swing=not params.towr_swing) if switched else params
        problem, more, seconds = attempt(task, model, terrain, run, initializer, callback, budget)
        label = f" ({'with' if run.towr_swing else 'without'} TOWR's swing constraint)" if switched else ""
        stages += [(name + label, r) for name, r in more]
        setup += seconds
        params = run
    problem, more, seconds = refine_range(problem, stages[-1][1], params, budget, callback)
    stages += more
    setup += seconds
    result = _combined(stages)
    if params.costs.active and not problem.costs:  # the last stage solved the constraints alone
        result.cost_terms = _cost_terms(problem, params, result.values)
        result.cost = sum(result.cost_terms.values())
    return PlanResult(problem, result, sample_solution(problem.form, result.values, com_offset=problem.com_offset),
                      setup)


class Budget:
    """What is left of `DynParams.iteration_budget` (None: unlimited) as stages spend it."""

    def __init__(self, total: int | None):
        self.left = total

    @property
    def spent(self) -> bool:
        return self.left is not None and self.left <= 0

    def solve(self, problem: Problem, solver: ALParams, callback) -> ALResult:
        """`solve_augmented_lagrangian` on the problem with at most what is left (possibly 0
        iterations: the stage then only reports where it stands)."""
        if self.left is not None:
            solver = replace(solver, max_iterations=min(solver.max_iterations, max(self.left, 0)))
        result = solve_augmented_lagrangian(problem.variables, problem.costs, problem.constraints, solver,
                                            callback=callback)
        if self.left is not None:
            self.left -= result.iterations
        if problem.timing is not None:  # what reads the solution reads it on its own timing
            problem.form = problem.timing.formulation(result.values[PHASES])
        elif problem.durations is not None:  # a fixed timing of the guess's: the next stage keeps it
            result.values[PHASES] = problem.durations
        return result


def direct(task: DynTask, model, terrain: TerrainModel, params: DynParams, initializer, budget: Budget,
           callback=None):
    """The whole problem (`params`' own sampling and costs) from the initializer's guess in one stage,
    by `DynParams.warm_solver`; returns (problem, [(stage name, result), ...], setup seconds). Measured
    on held-out pallet tasks from networks trained on 300: 11/12 and 17/24 converged within 25
    iterations, against 8/12 and 13/24 when the constraints were solved first and the costs after.
    With `DynParams.warm_stage` "projection": the same sampling without the costs, by
    `DynParams.projection_solver` (stage "projection"); "polish": that, then `polish` when the
    projected plan costs more than the initializer's `cost_bound` of the task (at
    `DynParams.polish_tolerance` times the filter's threshold). The range of motion
    is sampled also where the guess's feet come within `GUESS_RANGE_NEAR` of their boxes between the
    regular samples: its solution leaves the box there, which cost a `refine_range` round after
    the stage (measured on the first 60 held-out single-pallet tasks, projection: 38 of 60 within
    5 iterations before, 51 after)."""
    t0 = time.perf_counter()
    projection = params.warm_stage != "costs"
    problem = build_problem(task, model, terrain, replace(params, costs=CostWeights()) if projection else params,
                            initializer, near_range=GUESS_RANGE_NEAR)
    setup = time.perf_counter() - t0
    solver = params.projection_solver if projection else params.warm_solver
    stages = [("projection" if projection else "direct", budget.solve(problem, solver, callback))]
    if params.warm_stage == "polish" and params.costs.active and stages[0][1].success and not budget.spent:
        cost = sum(_cost_terms(problem, params, stages[0][1].values).values())
        if cost > initializer.cost_bound(task, params.polish_tolerance):
            problem, stages, seconds = polish(problem, stages[0][1], cost, params, budget, callback)
            setup += seconds
    return problem, stages, setup


POLISH_OUTER = 2  # outer iterations of the costs in `polish`
POLISH_RESERVE = 3  # LM iterations of the budget `polish` keeps for its last projection


def polish(problem: Problem, projected: ALResult, cost: float, params: DynParams, budget: Budget, callback=None):
    """Lower the cost of a projected plan (`DynParams.warm_stage` "polish"): `POLISH_OUTER` outer
    iterations of the costs by `DynParams.warm_solver` from it (where the cost settles: measured on
    held-out pallet tasks, the later outer iterations only bring the violation from about 1e-2 to
    1e-3, one LM iteration each), then the projection from there, within what is left of the
    budget, of which the costs leave that projection `POLISH_RESERVE` iterations (when they took
    it all, a long projection's plan was polished but could not be projected back, and its
    projection was kept: held-out task 54 at cost 7.96, polished 4.82). The polished plan is kept if
    it converged at a lower cost, else the projected one (the effort of both counted). Both keep
    the projection's extra range samples. Returns (problem, stages, setup seconds)."""
    solver = replace(params.warm_solver, max_outer=POLISH_OUTER)
    if budget.left is not None:  # what the projection after the costs needs is kept for it
        solver = replace(solver, max_iterations=max(budget.left - POLISH_RESERVE, 1))
    _, lowered, setup = _stage(problem.task, problem.model, problem.terrain, params, projected, solver, callback,
                               budget, problem.range_times)
    constraints = replace(params, costs=CostWeights())
    polished, result, seconds = _stage(problem.task, problem.model, problem.terrain, constraints, lowered,
                                       params.projection_solver, callback, budget, problem.range_times)
    setup += seconds
    stages = [("projection", projected), ("costs", lowered), ("projection after costs", result)]
    if result.success and sum(_cost_terms(polished, params, result.values).values()) < cost:
        return polished, stages, setup
    kept = replace(projected, iterations=0, outer_iterations=0, history=[], timings=Timings())  # its effort is counted
    return problem, stages + [("the projection kept (the polished plan did not converge lower)", kept)], setup


def _cost_terms(problem: Problem, params: DynParams, values: dict[str, np.ndarray]) -> dict[str, float]:
    """The terms of `params.costs` at the values, on the problem's formulation (whether or not the
    problem's own blocks include the costs)."""
    return evaluate_costs(cost_blocks(problem.form, problem.terrain, problem.model, params.costs), values)


def attempt(task: DynTask, model, terrain: TerrainModel, params: DynParams, initializer=heuristic, callback=None,
            budget: Budget | None = None):
    """Build and solve one task in stages (each warm-started from the one before); returns the last
    stage's problem, the (name, `ALResult`) of every stage and the setup seconds:

    1. feasibility — the constraints alone with the sampling and margin of `DynParams`, from the
       initializer (TOWR's problem with our between-node samples). Before the hinged LM's line search
       (`legplan.solve.hinged`) this took two stages, coarse sampling (swing every 0.05 s, range
       every 0.08 s, no margin) then fine: the pallet cases stalled when started fine. With it, one
       stage converges more often in fewer iterations (measured against the pair, both with the line
       search: the Heuristic on 200 held-out single-pallet tasks, N = 100, 96.5 % → 99.5 % converged,
       median 38 → 32 iterations, the same median cost; `bench/dyn.py` cases without costs 7 of 7
       either way, 2–3× fewer iterations on most (double pallet walk 27 → 12, stairs 99 → 84);
       with the paper's costs the double pallet walk converges again, 37 iterations);
    2. only if 1 stalls with TOWR's swing constraint on: again without it (it can over-constrain a
       tight gait, see `DynParams`), from where 1 stopped;
    3. only with costs: the costs, by the augmented Lagrangian from the feasible point
       (`DynParams.cost_solver`; measured: 3 of 3 pallet cases instead of 1 from the initializer);
    4. only if 3 ends short of the tolerance (its penalty can stall a few cm or N away) with budget
       left: feasibility again from there, which keeps most of the costs' effect and meets the
       constraints. Once the budget is spent the plan has not converged: a feasible point whose costs
       never ran (a budget spent before stage 3) or did not settle is not reported as a solution.
    A stage that fails ends the sequence. Iterations and timings add up over the stages; the reason
    names the stages that ran. `budget` (default: `DynParams.iteration_budget`) caps them together.
    """
    budget = Budget(params.iteration_budget) if budget is None else budget
    t0 = time.perf_counter()
    stage_params = replace(params, costs=CostWeights())
    problem = build_problem(task, model, terrain, stage_params, initializer)
    setup = time.perf_counter() - t0
    result = budget.solve(problem, params.solver, callback)
    stages = [("feasibility", result)]
    if not result.success and params.towr_swing:
        stage_params = replace(stage_params, towr_swing=False)
        problem, result, seconds = _stage(task, model, terrain, stage_params, result, params.solver, callback, budget)
        setup += seconds
        stages.append(("without TOWR's swing constraint", result))
    if result.success and params.costs.active:
        stage_params = replace(stage_params, costs=params.costs)
        problem, result, seconds = _stage(task, model, terrain, stage_params, result, params.cost_solver, callback, budget)
        setup += seconds
        stages.append(("costs", result))
        if not result.success and not budget.spent:  # near-feasible with lower costs: project it back
            stage_params = replace(stage_params, costs=CostWeights())
            problem, result, seconds = _stage(task, model, terrain, stage_params, result, params.solver, callback, budget)
            setup += seconds
            stages.append(("feasibility after costs", result))
    return problem, stages, setup


def refine_range(problem: Problem, result: ALResult, params: DynParams, budget: Budget, callback=None):
    """Keep the feet inside their range-of-motion boxes between the constraint's samples, not only at
    them (an exchange method for the continuous constraint): while a successful plan has a foot
    outside its box on the `RANGE_CHECK_DT` grid (`range_excess_times`), add those times to the
    constraint's samples and solve the constraints alone again from the plan (`DynParams.solver`),
    at most `RANGE_ROUNDS` times. Measured: with samples every 0.04 s the flat walk left the box by
    1.64 mm and the double pallet walk by 2.27 mm between samples (every 0.02 s: 0.19 and 0 mm,
    at up to a third more CPU). The costs stay out of it: a Gauss-Newton projection moves the plan
    by about the millimetres it is out, while the costs' augmented Lagrangian restarted from the plan
    with fresh multipliers first traded the constraints for lower costs again (1 N off the dynamics)
    and needed 7 or more iterations: from learned guesses with N_θ = 25, 3 of 12 held-out pallet
    tasks ran out of budget in this stage; feasibility only, none. Starts from the problem's own
    extra samples; an excess found only at times already sampled is within the solver's tolerance
    and ends it. Returns (problem, [(stage name, result)], setup seconds)."""
    stages, setup, times = [], 0.0, problem.range_times
    params, solver = replace(params, costs=CostWeights()), params.solver
    for _ in range(RANGE_ROUNDS):
        if not result.success or budget.spent:
            break
        found = np.setdiff1d(range_excess_times(problem, result.values), times)  # at a sample: within tolerance
        if not found.size:
            break
        times = np.union1d(times, found)
        problem, result, seconds = _stage(problem.task, problem.model, problem.terrain, params, result, solver,
                                          callback, budget, times)
        setup += seconds
        stages.append((f"range of motion at {times.size} more times", result))
    return problem, stages, setup


GUESS_RANGE_NEAR = 0.005
"""m: `direct` samples the range of motion also where a near-solution guess comes within this of a
box between the regular samples (`range_excess_times`), where its solution would likely leave the box
and need a `refine_range` round. Measured (projections of the first 60 held-out single-pallet tasks,
converged within 5 iterations): none 63 %, where the guess is outside (0 m) 72 %, 5, 10 or 20 mm 85 %."""
RANGE_ROUNDS = 3


def _stage(task, model, terrain, params: DynParams, previous: ALResult, solver, callback, budget: Budget,
           range_times: np.ndarray = ()):
    """Build the problem of one stage from the previous stage's values and solve it."""
    t0 = time.perf_counter()
    problem = build_problem(task, model, terrain, params, lambda *_: previous.values, range_times)
    seconds = time.perf_counter() - t0
    return problem, budget.solve(problem, solver, callback), seconds


def _combined(stages: list[tuple[str, ALResult]]) -> ALResult:
    """The last stage's result with the effort of all stages added and a reason naming them."""
    last = stages[-1][1]
    if len(stages) == 1:
        return last
    for _, earlier in stages[:-1]:
        for name in ("evaluate", "assemble", "factorize", "solve", "total"):
            setattr(last.timings, name, getattr(last.timings, name) + getattr(earlier.timings, name))
        last.iterations += earlier.iterations
        last.outer_iterations += earlier.outer_iterations
    last.history = [dict(h, stage=name) for name, r in stages for h in r.history]
    last.first_iteration_seconds = stages[0][1].first_iteration_seconds
    last.reason = "; ".join(f"{name}: {r.reason}" for name, r in stages)
    return last


def sample_solution(form: Formulation, values: dict[str, np.ndarray], dt: float = SAMPLE_DT,
                    com_offset=None) -> dict[str, np.ndarray]:
    """Base pose, velocities and accelerations (world ω, ω̇ from the Euler spline), feet, forces and
    contact flags at t = 0, dt, ..., T. The spline is the CoM's; the base origin lies at
    −`com_offset` (the CoM in the base frame) from it: p = c − R o, ṗ = ċ − ω × R o,
    p̈ = c̈ − ω̇ × R o − ω × (ω × R o)."""
    t = np.append(np.arange(0.0, form.duration - 1e-9, dt), form.duration)
    lin = values["base_lin"].reshape(-1, 3)
    ang = values["base_ang"].reshape(-1, 3)
    p, v, a = (form.base_matrix(t, d) @ lin for d in range(3))
    e, ed, edd = (form.base_matrix(t, d) @ ang for d in range(3))
    w, wd = world_rates(e, ed, edd)
    if com_offset is not None and np.any(com_offset):
        arm = rotation(e) @ np.asarray(com_offset, float)
        p, v, a = p - arm, v - np.cross(w, arm), a - np.cross(wd, arm) - np.cross(w, np.cross(w, arm))
    feet = values["feet"].reshape(-1, 3)
    forces = values["forces"].reshape(-1, 3)
    legs = range(form.legs)
    return {"t": t, "base_pos": p, "base_vel": v, "base_acc": a, "base_euler": e, "base_euler_rate": ed,
            "base_ang_vel": w, "base_ang_acc": wd,
            "feet_pos": np.stack([form.foot_matrix(k, t) @ feet for k in legs], axis=1),
            "feet_vel": np.stack([form.foot_matrix(k, t, 1) @ feet for k in legs], axis=1),
            "forces": np.stack([form.force_matrix(k, t) @ forces for k in legs], axis=1),
            "contact": form.gait.contact(t)}
