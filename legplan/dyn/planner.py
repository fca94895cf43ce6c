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

from legplan.dyn.euler import world_rates
from legplan.dyn.formulation import Formulation
from legplan.dyn.init import heuristic
from legplan.dyn.problem import DynParams, DynTask, Problem, build_problem
from legplan.dyn.terrain import TerrainModel
from legplan.solve.auglag import ALResult, solve_augmented_lagrangian

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
    """Build, solve and sample one task (see module docstring)."""
    t0 = time.perf_counter()
    problem = build_problem(task, model, terrain, params, initializer)
    setup = time.perf_counter() - t0
    result = solve_augmented_lagrangian(problem.variables, problem.costs, problem.constraints, params.solver,
                                        callback=callback)
    if not result.success and params.towr_swing:
        # TOWR's swing constraint can over-constrain a tight gait (DynParams): continue without it
        t0 = time.perf_counter()
        stalled = result
        problem = build_problem(task, model, terrain, replace(params, towr_swing=False), lambda *_: stalled.values)
        setup += time.perf_counter() - t0
        result = _continued(stalled, solve_augmented_lagrangian(problem.variables, problem.costs, problem.constraints,
                                                                params.solver, callback=callback))
    return PlanResult(problem, result, sample_solution(problem.form, result.values), setup)


def _continued(first: ALResult, second: ALResult) -> ALResult:
    """The second solve, with the effort of the first added and the reason saying what happened."""
    for name in ("evaluate", "assemble", "factorize", "solve", "total"):
        setattr(second.timings, name, getattr(first.timings, name) + getattr(second.timings, name))
    second.iterations += first.iterations
    second.outer_iterations += first.outer_iterations
    second.history = first.history + second.history
    second.first_iteration_seconds = first.first_iteration_seconds
    second.reason = f"{second.reason} (after dropping TOWR's swing constraint: {first.reason})"
    return second


def sample_solution(form: Formulation, values: dict[str, np.ndarray], dt: float = SAMPLE_DT) -> dict[str, np.ndarray]:
    """Base pose, velocities and accelerations (world ω, ω̇ from the Euler spline), feet, forces and
    contact flags at t = 0, dt, ..., T."""
    t = np.append(np.arange(0.0, form.duration - 1e-9, dt), form.duration)
    lin = values["base_lin"].reshape(-1, 3)
    ang = values["base_ang"].reshape(-1, 3)
    p, v, a = (form.base_matrix(t, d) @ lin for d in range(3))
    e, ed, edd = (form.base_matrix(t, d) @ ang for d in range(3))
    w, wd = world_rates(e, ed, edd)
    feet = values["feet"].reshape(-1, 3)
    forces = values["forces"].reshape(-1, 3)
    legs = range(form.legs)
    return {"t": t, "base_pos": p, "base_vel": v, "base_acc": a, "base_euler": e, "base_euler_rate": ed,
            "base_ang_vel": w, "base_ang_acc": wd,
            "feet_pos": np.stack([form.foot_matrix(k, t) @ feet for k in legs], axis=1),
            "feet_vel": np.stack([form.foot_matrix(k, t, 1) @ feet for k in legs], axis=1),
            "forces": np.stack([form.force_matrix(k, t) @ forces for k in legs], axis=1),
            "contact": form.gait.contact(t)}
