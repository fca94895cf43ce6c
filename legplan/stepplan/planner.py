"""Algorithm 1 (PlanStep) of the Bézier step-planning paper: degree elevation + SolveLM per degree.

Vector parametrization: a configuration q (pinocchio order: base position, base quaternion,
joints) maps to x = [p, ω, joints] ∈ R^nv with ω the rotation vector of the base orientation
(eq. (1b), `robot.to_vector`). Consecutive steps differ by small rotations, so ω interpolates well;
the ω of q_end is unwrapped towards that of q_start (`unwrap_rotation_vector`), so the curve never
takes the long way round. The path is π(t) = Σ_i B_i^d(t) p_i in x-space (eq. (6)), p_0 = x(q_start),
p_d = x(q_end).

PlanStep: start from the line (d = 1); at each degree elevate by eq. (7), reset ξ = 0 and run
SolveLM (`legplan.solve.solve_lm`, Algorithm 1 with Table I damping) on F̃_ε,N (eq. (12)), warm
started from the elevated control points; stop at the first degree with ‖F̃‖ ≤ ε_num. At d = 1 there
is no free control point, so the only unknowns are the slacks, solved in closed form: ξ_k = f_k
zeroes eq. (11a) and F̃ = 0 iff every sample meets the inequalities and ‖f‖ ≤ ε per foot.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from legplan.contact.terms import ContactMode, collision_reach
from legplan.geometry.bezier import elevate, uniform_parameters
from legplan.solve import LMParams, Problem, VariableBlock, solve_lm
from legplan.stepplan.block import BezierConstraintBlock, SampleConstraints
from legplan.stepplan.params import StepPlanParams
from legplan.terrain.columns import ColumnDistance

log = logging.getLogger(__name__)


def unwrap_rotation_vector(omega, reference) -> np.ndarray:
    """The rotation vector of the same rotation as `omega` that lies closest to `reference`.

    ω and ω − 2π ω/‖ω‖ (and further multiples) describe the same rotation; pick the nearest.
    """
    omega = np.asarray(omega, float)
    angle = np.linalg.norm(omega)
    if angle < 1e-12:
        return omega.copy()
    axis = omega / angle
    candidates = [(angle + 2 * np.pi * k) * axis for k in (-2, -1, 0, 1)]
    return min(candidates, key=lambda c: np.linalg.norm(c - reference))


def path_vectors(robot, q_start, q_end) -> tuple[np.ndarray, np.ndarray]:
    """End control points x(q_start), x(q_end) with the end rotation vector unwrapped towards the start."""
    x0, x1 = robot.to_vector(np.stack([q_start, q_end]))
    x1 = x1.copy()
    x1[3:6] = unwrap_rotation_vector(x1[3:6], x0[3:6])
    return x0, x1


@dataclass
class DegreeRecord:
    """One pass of the loop in Algorithm 1."""

    degree: int
    iterations: int
    norm: float
    status: str
    seconds: float


@dataclass
class StepPlan:
    """Outcome of PlanStep for one pair of configurations."""

    control_points: np.ndarray  # (d+1, nx) in x-space, of the last degree tried
    degree: int
    success: bool
    reason: str
    norm: float
    degrees: list[DegreeRecord] = field(default_factory=list)
    seconds: float = 0.0
    timings: dict[str, float] = field(default_factory=dict)  # evaluate / assemble / factorize / solve


def contact_mode(stance, footholds, params: StepPlanParams) -> ContactMode:
    return ContactMode(stance=stance, footholds=footholds, com_margin=params.com_margin,
                       clearance=params.clearance, foot_clearance=0.0)


def terrain_distance(robot, terrain, params) -> ColumnDistance:
    """The exact terrain distance of `terrain` (a `TerrainMap`) for the collision rows of `contact_mode`:
    exact up to the largest distance at which one can be active (`collision_reach`)."""
    return ColumnDistance.of(terrain, collision_reach(robot, params.sample_clearance))


def plan_step(robot, sdf, q_start, q_end, stance, footholds, params: StepPlanParams = StepPlanParams()) -> StepPlan:
    """PlanStep(q_start, q_end, ε, N, d_max) of Algorithm 1.

    `stance` (n_legs,) bool marks the legs whose feet stay on `footholds` (n_legs, 3) for the whole
    motion; the other legs swing freely (no equality constraint, collision only). `sdf` is the
    terrain distance of the collision rows (`terrain_distance` for the exact one).
    """
    t_start = time.perf_counter()
    x0, x1 = path_vectors(robot, np.asarray(q_start, float), np.asarray(q_end, float))
    ends = robot.sphere_centres(robot.from_vector(np.stack([x0, x1])))
    constraints = SampleConstraints(robot, sdf, contact_mode(stance, footholds, params),
                                    params.slack_fraction * params.epsilon, swing_ends=ends,
                                    relax_radius=params.relax_radius,
                                    headroom=params.sample_clearance - params.clearance)
    t = uniform_parameters(params.samples + 1)[1:-1]  # interior t_i = i/N; the ends are fixed
    lm = LMParams(lambda_init=params.lambda_init, lambda_drop=params.lambda_drop,
                  lambda_boost=params.lambda_boost, max_iterations=params.max_iterations,
                  tolerance=params.eps_num, linear_solver=params.linear_solver, assembly=params.assembly,
                  stall_window=params.stall_window)
    timings = {"evaluate": 0.0, "assemble": 0.0, "factorize": 0.0, "solve": 0.0}
    P = np.stack([x0, x1])
    records: list[DegreeRecord] = []
    norm = np.inf
    for degree in range(1, params.max_degree + 1):
        t0 = time.perf_counter()
        if degree > 1:
            P = elevate(P)  # eq. (7)
        block = BezierConstraintBlock(constraints, degree, t)
        if degree == 1:
            norm = _linear_norm(block, P)
            iterations, status = 0, ("converged" if norm <= params.eps_num else "closed_form")
        else:
            problem = Problem([control_point_variable(P),
                               VariableBlock("xi", np.zeros(len(t) * constraints.slack_size),
                                             schur_block=constraints.slack_size)])
            problem.add_residual(block)
            result = solve_lm(problem, lm)
            P = result.values["P"].reshape(degree + 1, -1)
            norm, iterations, status = result.norm, result.iterations, result.status.value
            for key in timings:
                timings[key] += getattr(result.timings, key)
        records.append(DegreeRecord(degree, iterations, float(norm), status, time.perf_counter() - t0))
        log.debug("degree %d: ‖F̃‖ = %.3e after %d iterations (%s)", degree, norm, iterations, status)
        if norm <= params.eps_num:
            return StepPlan(P, degree, True, "", float(norm), records, time.perf_counter() - t_start, timings)
    reason = (f"no degree up to d_max = {params.max_degree} reached ‖F̃‖ ≤ ε_num = {params.eps_num:.1e}; "
              f"last ‖F̃‖ = {norm:.3e}")
    return StepPlan(P, params.max_degree, False, reason, float(norm), records, time.perf_counter() - t_start, timings)


def control_point_variable(P: np.ndarray) -> VariableBlock:
    """Variable "P": all control points (d+1, nx) flattened, the end points p_0, p_d fixed."""
    fixed = np.zeros(P.shape, bool)
    fixed[[0, -1]] = True
    return VariableBlock("P", P.reshape(-1), fixed=fixed.reshape(-1))


def _linear_norm(block: BezierConstraintBlock, P: np.ndarray) -> float:
    """‖F̃‖ of the straight line with the optimal slacks ξ_k = f_k (no free control point at d = 1)."""
    flat = P.reshape(-1)
    zeros = np.zeros(block.samples * block.constraints.slack_size)
    r = block.evaluate([flat, zeros], False)[0].reshape(block.samples, -1)
    f = r[:, :block.constraints.slack_size]  # rows f − ξ with ξ = 0
    return float(np.linalg.norm(block.evaluate([flat, f.reshape(-1)], False)[0]))
