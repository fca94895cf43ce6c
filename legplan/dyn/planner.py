"""Plan one centroidal trajectory: build the problem, solve it in declared stages, sample it every 10 ms.

    result = plan(DynTask(start=(0, 0, 0), goal=(1, 0, 0), gait="trot", strides=4, duration=2.4),
                  model, TerrainModel(load_map("map.h5")), DynParams())
    result.status, [(s.name, s.status) for s in result.stages], result.samples["base_pos"]

The solve is a schedule of `Stage`s, data (`schedule`): each says whether it solves the costs under
the constraints or the constraints alone, which of `DynParams`' solver settings it uses
(`legplan.solve.solve_augmented_lagrangian`, the augmented Lagrangian over the hinged LM), where it
starts (the initializer's guess, or the last stage's solution), which extra range-of-motion samples
it adds, and when it runs (`When`: after a success, after a failure, ...). `plan` is one loop over
the schedule; `Budget` only counts the LM iterations of `DynParams.iteration_budget` (Algorithm 1's
N). Every stage that ran is a `StageOutcome` with its `Status`; the plan's status is the last one's.

The schedule (the paper's two initializers, Sec. IV):

* From a guess that solves a nearby task (an initializer with ``near_solution`` true: the learned
  one, A_θ), from the guess: "direct" (the costs under the constraints, by `warm_solver`), which
  stops once its cost settled (`ALParams.settled_exit`) and, if a row is still outside its
  tolerance then, "projection after direct" (the constraints alone, `projection_solver`, to the
  same tolerances); or with `DynParams.warm_stage` "projection" the constraints alone
  (`projection_solver`); either with range samples also where the guess's feet come within
  `GUESS_RANGE_NEAR` of their boxes. The projection finishes what the augmented Lagrangian would
  finish over several outer iterations: from a guess at a solution, the first subproblem's soft
  penalty on the Newton–Euler rows (scaled per the robot's weight, held to 1e-3 N) lets them drift
  by about a newton while the cost has already settled, and multiplier updates with μ raised ×10 at a
  time take one subproblem each to bring them back, a Gauss–Newton projection a few steps. With
  "polish", a projected plan that costs more than the initializer's training filter kept for the
  task (eq. (4), at `polish_tolerance`) gets `POLISH_OUTER` outer iterations of the costs and a
  projection back; the polished plan is kept only if it converged at a lower cost.
* Otherwise, or when that failed: "feasibility", the constraints alone from the guess (TOWR's
  problem with our between-node samples); with TOWR's swing constraint on and a failure, again
  without it from there; with costs, "costs" from the feasible point (`cost_solver`), and if those
  end short of the tolerance, "feasibility after costs" from there. If the attempt fails, the same
  again from the guess with TOWR's swing constraint switched (`DynParams.towr_swing`).
* A successful plan then gets up to `RANGE_ROUNDS` "range of motion" stages: while a foot leaves its
  box between the constraint's samples (`range_excess_times`), those times become samples and the
  constraints alone are solved again from the plan (an exchange method for the continuous
  constraint; the costs stay out of it, so the plan moves by about the millimetres it is out).
  On a level map, whose problem leaves the leg-clearance rows out, such a stage also runs when a
  leg sphere of the plan touches the ground at a plan sample (`legs_touch_level_ground`: a crouched
  robot's shanks), and from then on the rows hold there too, with their margin.

A stage that follows a failure needs budget left; the costs stage runs after a feasible stage even
with the budget spent, so that a plan whose costs never ran is not reported as a solution.
"""

from __future__ import annotations

import enum
import time
from dataclasses import dataclass, field, replace

import numpy as np

from legplan.dyn.costs import CostWeights
from legplan.dyn.euler import rotation, world_rates
from legplan.dyn.formulation import Formulation
from legplan.dyn.init import heuristic
from legplan.dyn.problem import (SAMPLE_DT, DynParams, DynProblem, DynTask, build_problem, cost_blocks,
                                 legs_touch_level_ground, range_excess_times, sample_grid)
from legplan.dyn.terrain import TerrainModel
from legplan.dyn.timing import PHASES
from legplan.geometry.ordered import sorted_difference, sorted_union
from legplan.solve.auglag import ALParams, ALResult, evaluate_costs, solve_augmented_lagrangian
from legplan.solve.lm import Status, Timings

POLISH_OUTER = 2  # outer iterations of the costs when polishing a projected plan
POLISH_RESERVE = 3  # LM iterations of the budget the polishing costs leave for the projection after them
RANGE_ROUNDS = 3  # "range of motion" stages after a successful plan, at most
GUESS_RANGE_NEAR = 0.005
"""m: a stage from a near-solution guess samples the range of motion also where the guess comes
within this of a box between the regular samples (`range_excess_times`): its solution would likely
leave the box there and need a "range of motion" stage."""


class When(enum.Enum):
    """When a stage of the schedule runs. START opens an attempt; the next four run only inside an
    attempt that started."""

    START = "start"  # first, or after a failed stage: a new attempt
    FAILED = "failed"  # the schedule's previous stage ran and failed
    SUCCEEDED = "succeeded"  # the last stage that ran succeeded
    ABOVE_BOUND = "above_bound"  # the previous stage ran, succeeded and costs more than the guess's bound
    AFTER = "after"  # the previous stage ran
    PLAN_SUCCEEDED = "plan_succeeded"  # the last stage that ran succeeded, whichever attempt it ended


class Start(enum.Enum):
    """Where a stage starts and which extra range-of-motion samples it has."""

    GUESS = "guess"  # the initializer's guess, the regular samples
    NEAR_GUESS = "near_guess"  # the guess, also sampled where it comes near a box (`GUESS_RANGE_NEAR`)
    PREVIOUS = "previous"  # the last stage's solution and samples
    RANGE_EXCESS = "range_excess"  # that, also sampled where it leaves a box (skipped when it does not)


@dataclass(frozen=True)
class Stage:
    """One solve of the schedule: `name`; with the `costs` or the constraints alone; `solver`, the
    `DynParams` field of its `ALParams`, with its outer iterations capped at `max_outer` (None: the
    solver's); `start`; TOWR's swing constraint on or off (`towr_swing`, None: as the stage it starts
    from, or `DynParams.towr_swing` from the guess); when it runs (`when`) and whether it needs
    iterations of the budget left (`needs_budget`, after another stage); `reserve`: iterations of the
    budget it leaves to the stages after it; `keeps_better`: the plan it polishes stays unless this
    stage converged at a lower cost; `settled_exit`: a costs stage stops once its cost settled,
    leaving rows outside their tolerance to the next stage (`ALParams.settled_exit`)."""

    name: str
    costs: bool
    solver: str
    when: When
    start: Start = Start.PREVIOUS
    towr_swing: bool | None = None
    needs_budget: bool = True
    max_outer: int | None = None
    reserve: int = 0
    keeps_better: bool = False
    settled_exit: bool = False


def schedule(params: DynParams, near_solution: bool = False) -> list[Stage]:
    """The stages `plan` runs for `params` and an initializer whose guesses are (`near_solution`) or
    are not solutions of nearby tasks (module docstring)."""
    stages = []
    if near_solution and (params.costs.active or params.warm_stage != "costs"):
        if params.warm_stage == "costs":
            stages += [Stage("direct", True, "warm_solver", When.START, Start.NEAR_GUESS, settled_exit=True),
                       Stage("projection after direct", False, "projection_solver", When.FAILED)]
        else:
            stages.append(Stage("projection", False, "projection_solver", When.START, Start.NEAR_GUESS))
            if params.warm_stage == "polish" and params.costs.active:
                stages += [Stage("costs", True, "warm_solver", When.ABOVE_BOUND, max_outer=POLISH_OUTER,
                                 reserve=POLISH_RESERVE),
                           Stage("projection after costs", False, "projection_solver", When.AFTER,
                                 needs_budget=False, keeps_better=True)]
    for swing in (params.towr_swing, not params.towr_swing):
        label = "" if swing == params.towr_swing else f" ({'with' if swing else 'without'} TOWR's swing constraint)"
        stages.append(Stage("feasibility" + label, False, "solver", When.START, Start.GUESS, towr_swing=swing))
        if swing:
            stages.append(Stage("without TOWR's swing constraint" + label, False, "solver", When.FAILED,
                                towr_swing=False))
        if params.costs.active:
            stages += [Stage("costs" + label, True, "cost_solver", When.SUCCEEDED, needs_budget=False),
                       Stage("feasibility after costs" + label, False, "solver", When.FAILED)]
    stages += [Stage("range of motion", False, "solver", When.PLAN_SUCCEEDED, Start.RANGE_EXCESS)] * RANGE_ROUNDS
    return stages


@dataclass
class StageOutcome:
    """A stage that ran: its name, why its solver stopped, the solver's result, the problem it solved
    (on the solution's timing) and the seconds spent building that problem."""

    name: str
    status: Status
    result: ALResult
    problem: DynProblem
    setup_seconds: float = 0.0
    towr_swing: bool = False

    @property
    def success(self) -> bool:
        return self.status is Status.CONVERGED


@dataclass
class PlanResult:
    """The stages that ran, the last one's problem, the combined solver outcome (the last stage's
    solution, the effort of all) and the solution sampled every `SAMPLE_DT`."""

    problem: DynProblem
    stages: list[StageOutcome]
    solve: ALResult
    samples: dict[str, np.ndarray]
    setup_seconds: float

    @property
    def status(self) -> Status:
        return self.stages[-1].status

    @property
    def success(self) -> bool:
        return self.status is Status.CONVERGED

    @property
    def reason(self) -> str:
        """The solver's reason, prefixed by the stage's name for each stage when several ran."""
        if len(self.stages) == 1:
            return self.stages[0].result.reason
        return "; ".join(f"{s.name}: {s.result.reason}" for s in self.stages)


class Budget:
    """What is left of `DynParams.iteration_budget` (None: unlimited); it only counts."""

    def __init__(self, total: int | None):
        self.left = total

    @property
    def spent(self) -> bool:
        return self.left is not None and self.left <= 0

    def cap(self, solver: ALParams, reserve: int = 0) -> ALParams:
        """`solver` with at most what is left (possibly 0 iterations: the stage then reports where it
        stands), less `reserve` but at least 1 when a reserve is kept."""
        if self.left is None:
            return solver
        cap = max(self.left, 0) if not reserve else min(max(self.left - reserve, 1), max(self.left, 0))
        return replace(solver, max_iterations=min(solver.max_iterations, cap))

    def spend(self, iterations: int) -> None:
        if self.left is not None:
            self.left -= iterations


def plan(task: DynTask, model, terrain: TerrainModel, params: DynParams = DynParams(), initializer=heuristic,
         callback=None) -> PlanResult:
    """Build, solve (the stages of `schedule`) and sample one task; `callback(iteration, violation,
    cost)` follows every solve."""
    budget = Budget(params.iteration_budget)
    outcomes: list[StageOutcome] = []
    attempt = ran_previous = False  # whether the last START stage ran; whether the previous stage ran
    polishing: tuple[StageOutcome, float] | None = None  # the plan being polished and its cost
    for stage in schedule(params, getattr(initializer, "near_solution", False)):
        last = outcomes[-1] if outcomes else None
        runs = _runs(stage, last, attempt, ran_previous, budget)
        if stage.when is When.START:
            attempt = runs
        if not runs:
            ran_previous = False
            continue
        if stage.when is When.ABOVE_BOUND:
            cost = _plan_cost(last.problem, params, last.result.values)
            if cost <= initializer.cost_bound(task, params.polish_tolerance):
                ran_previous = False
                continue
            polishing = (last, cost)
        outcome = _run_stage(stage, task, model, terrain, params, initializer, last, budget, callback)
        ran_previous = outcome is not None
        if outcome is None:  # nothing to refine
            continue
        outcomes.append(outcome)
        if stage.keeps_better and polishing is not None:
            kept, cost = polishing
            if not (outcome.success and _plan_cost(outcome.problem, params, outcome.result.values) < cost):
                effortless = replace(kept.result, iterations=0, outer_iterations=0, history=[], timings=Timings())
                outcomes.append(replace(kept, name="projection kept", result=effortless, setup_seconds=0.0))
    final = outcomes[-1]
    solve = _combined(outcomes)
    if params.costs.active and not final.problem.costs:  # the last stage solved the constraints alone
        solve.cost_terms = _cost_terms(final.problem, params, solve.values)
        solve.cost = sum(solve.cost_terms.values())
    samples = sample_solution(final.problem.form, solve.values, com_offset=final.problem.com_offset)
    return PlanResult(final.problem, outcomes, solve, samples, sum(s.setup_seconds for s in outcomes))


def _runs(stage: Stage, last: StageOutcome | None, attempt: bool, ran_previous: bool, budget: Budget) -> bool:
    """Whether `stage` runs after the outcomes so far (`When`, and the budget where it needs one)."""
    if last is not None and stage.needs_budget and budget.spent:
        return False
    if stage.when is When.START:
        return last is None or not last.success
    if stage.when is When.PLAN_SUCCEEDED:
        return last is not None and last.success
    if not attempt:
        return False
    if stage.when is When.FAILED:
        return ran_previous and not last.success
    if stage.when is When.SUCCEEDED:
        return last is not None and last.success
    if stage.when is When.ABOVE_BOUND:
        return ran_previous and last.success
    return ran_previous  # When.AFTER


@dataclass(frozen=True)
class _Previous:
    """The initializer of a stage that starts from the last stage's solution: its values, which
    carry phase durations (`PHASES`) when a timing was set or optimized, so that the stage builds the
    same variable layout (`problem.task_formulation`'s timed knots) as the stage that produced them."""
    values: dict

    @property
    def sets_timing(self) -> bool:
        return PHASES in self.values

    def __call__(self, *_):
        return self.values


def _run_stage(stage: Stage, task: DynTask, model, terrain: TerrainModel, params: DynParams, initializer,
               last: StageOutcome | None, budget: Budget, callback) -> StageOutcome | None:
    """Build the stage's problem and solve it within the budget; None for a "range of motion" stage
    that finds no foot outside its box at a time not yet sampled (an excess found only at sampled
    times is within the solver's tolerance)."""
    from_guess = stage.start in (Start.GUESS, Start.NEAR_GUESS)
    swing = stage.towr_swing if stage.towr_swing is not None else (
        params.towr_swing if from_guess else last.towr_swing)
    stage_params = replace(params, costs=params.costs if stage.costs else CostWeights(), towr_swing=swing)
    t0 = time.perf_counter()
    if from_guess:
        near = GUESS_RANGE_NEAR if stage.start is Start.NEAR_GUESS else None
        problem = build_problem(task, model, terrain, stage_params, initializer, near_range=near)
    else:
        times, level_legs = last.problem.range_times, last.problem.level_legs
        if stage.start is Start.RANGE_EXCESS:
            found = sorted_difference(range_excess_times(last.problem, last.result.values), times)
            touching = legs_touch_level_ground(last.problem, params, last.result.values)
            if not found.size and not touching:
                return None
            times, level_legs = sorted_union(times, found), level_legs or touching
        problem = build_problem(task, model, terrain, stage_params, _Previous(last.result.values), times,
                                level_legs=level_legs)
    setup = time.perf_counter() - t0
    solver = getattr(params, stage.solver)
    if stage.max_outer is not None:
        solver = replace(solver, max_outer=stage.max_outer)
    if stage.settled_exit:
        solver = replace(solver, settled_exit=True)
    result = solve_augmented_lagrangian(problem.variables, problem.costs, problem.constraints,
                                        budget.cap(solver, stage.reserve), callback=callback)
    budget.spend(result.iterations)
    if problem.timing is not None:  # what reads the solution reads it on its own timing
        problem = replace(problem, form=problem.timing.formulation(result.values[PHASES]))
    elif problem.durations is not None:  # a fixed timing of the guess's: the next stage keeps it
        result.values[PHASES] = problem.durations
    return StageOutcome(stage.name, result.status, result, problem, setup, swing)


def _plan_cost(problem: DynProblem, params: DynParams, values: dict[str, np.ndarray]) -> float:
    return sum(_cost_terms(problem, params, values).values())


def _cost_terms(problem: DynProblem, params: DynParams, values: dict[str, np.ndarray]) -> dict[str, float]:
    """The terms of `params.costs` at the values, on the problem's formulation (whether or not the
    problem's own blocks include the costs)."""
    return evaluate_costs(cost_blocks(problem.form, problem.terrain, problem.model, params.costs), values)


def _combined(outcomes: list[StageOutcome]) -> ALResult:
    """The last stage's result with the effort of every stage added (iterations, timings, history
    rows labelled by stage) and the first stage's first-iteration time."""
    last = outcomes[-1].result
    timings = Timings()
    for name in ("evaluate", "assemble", "factorize", "solve", "total"):
        setattr(timings, name, sum(getattr(s.result.timings, name) for s in outcomes))
    return replace(last, values=dict(last.values), cost_terms=dict(last.cost_terms),
                   iterations=sum(s.result.iterations for s in outcomes),
                   outer_iterations=sum(s.result.outer_iterations for s in outcomes),
                   history=[dict(h, stage=s.name) for s in outcomes for h in s.result.history], timings=timings,
                   first_iteration_seconds=outcomes[0].result.first_iteration_seconds,
                   reason="; ".join(f"{s.name}: {s.result.reason}" for s in outcomes)
                   if len(outcomes) > 1 else last.reason)


def sample_solution(form: Formulation, values: dict[str, np.ndarray], dt: float = SAMPLE_DT,
                    com_offset=None) -> dict[str, np.ndarray]:
    """Base pose, velocities and accelerations (world ω, ω̇ from the Euler spline), feet, forces and
    contact flags at t = 0, dt, ..., T. The spline is the CoM's; the base origin lies at
    −`com_offset` (the CoM in the base frame) from it: p = c − R o, ṗ = ċ − ω × R o,
    p̈ = c̈ − ω̇ × R o − ω × (ω × R o)."""
    t = sample_grid(form.duration, dt)
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
