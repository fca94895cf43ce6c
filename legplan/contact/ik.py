"""Whole-body IK of one configuration with the sparse LM core (Algorithm 1, eq. (13)).

The residual h(x) stacks the constraint terms of `legplan.contact.terms` at one configuration:
stance feet on their footholds and optional foot targets (equalities, eq. (4a)), CoM inside the
support polygon with a margin and spheres clear of the terrain SDF (inequalities through
`HingeInequality`, eq. (8b)); joint limits are box bounds on x, which the solver projects onto.
A first solve adds a posture term w (x - x_ref) (nominal body height above the footholds,
orientation, joints) that picks one configuration of the many satisfying the constraints; a
second solve without it removes the small bias the regularisation leaves in the constraints.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from legplan.contact.terms import (ContactMode, collision_terms, com_terms, foot_target_terms,
                                   sphere_margins, stance_foot_terms)
from legplan.solve import FunctionBlock, HingeInequality, LMParams, Problem, VariableBlock, solve_lm


@dataclass(frozen=True)
class Posture:
    """Regularisation target x_ref (nx,) and per-entry weights (nx,) (0 = free)."""

    reference: np.ndarray
    weights: np.ndarray


@dataclass
class IKResult:
    """Solution x (nx,) / q (nq,) and the worst constraint values at it (m; <= 0 means satisfied)."""

    x: np.ndarray
    q: np.ndarray
    success: bool
    reason: str
    foot_error: float
    com_violation: float
    collision_violation: float
    iterations: int = 0
    stages: list[str] = field(default_factory=list)


class _TermCache:
    """All constraint terms of one configuration, evaluated together and kept for the last x.

    Every block of `constraint_blocks` reads its rows from here, so the kinematics run once per
    point (the LM evaluates a trial point, then linearises at it when it is accepted).
    """

    def __init__(self, terms: dict):
        self.terms = terms  # name -> batched term fn(X, Q) -> (values (1, m), jac (1, m, nx))
        self._key: bytes | None = None
        self._values: dict = {}

    def block(self, robot, name: str):
        def fn(x):
            key = np.asarray(x, float).tobytes()
            if key != self._key:
                X = np.asarray(x, float)[None, :]
                Q = robot.from_vector(X)
                self._values = {n: term(X, Q) for n, term in self.terms.items()}
                self._key = key
            values, jac = self._values[name]
            return values[0], [jac[0]]
        return fn


def constraint_blocks(robot, sdf, mode: ContactMode, targets: dict[int, np.ndarray] | None = None):
    """Residual blocks over variable "x" for one configuration: [(block, kind)] with kind eq|ineq."""
    terms, sizes, kinds = {}, {}, {}
    k = int(mode.stance.sum())
    if k:
        terms["stance"] = lambda X, Q: stance_foot_terms(robot, X, mode, Q)
        sizes["stance"], kinds["stance"] = 3 * k, "eq"
    if targets:
        legs = sorted(targets)
        pts = np.array([targets[leg] for leg in legs])
        terms["targets"] = lambda X, Q: foot_target_terms(robot, X, legs, pts, Q)
        sizes["targets"], kinds["targets"] = 3 * len(legs), "eq"
    terms["com"] = lambda X, Q: com_terms(robot, X, mode, Q)
    sizes["com"], kinds["com"] = len(mode.polygon.b), "com"
    if sdf is not None:
        terms["collision"] = lambda X, Q: collision_terms(robot, X, mode, sdf, Q)
        sizes["collision"] = int(np.sum(~np.isnan(sphere_margins(robot, mode))))
        kinds["collision"] = "collision"
    cache = _TermCache(terms)
    blocks = []
    for name in terms:
        block = FunctionBlock(["x"], sizes[name], cache.block(robot, name))
        blocks.append((block if kinds[name] == "eq" else HingeInequality(block), kinds[name]))
    return blocks


def _joint_bounds(robot):
    nx, nj = robot.nv, robot.n_joints
    lower = np.full(nx, -np.inf)
    upper = np.full(nx, np.inf)
    lower[nx - nj:] = robot.lower
    upper[nx - nj:] = robot.upper
    return lower, upper


def solve_ik(robot, sdf, mode: ContactMode, x0, *, targets: dict[int, np.ndarray] | None = None,
             posture: Posture | None = None, soft_targets: dict[int, np.ndarray] | None = None,
             soft_weight: float = 1.0, foot_tolerance: float = 1e-4, max_iterations: int = 100,
             posture_step_tolerance: float = 1e-6) -> IKResult:
    """Find x near x0 satisfying `mode` (and foot `targets`); see the module docstring.

    `soft_targets` (leg -> point) join the posture term of the first solve with `soft_weight`
    (e.g. keep a lifted foot up); they are not constraints. The regularised solve stops when its
    step falls below `posture_step_tolerance` relative to |x|.
    """
    lower, upper = _joint_bounds(robot)
    x = np.clip(np.asarray(x0, float), lower, upper)
    blocks = constraint_blocks(robot, sdf, mode, targets)
    polish = LMParams(max_iterations=max_iterations, linear_solver="dense", tolerance=1e-9)
    # the regularised solve only has to land near a good configuration: stop once its steps are small
    regularise = replace(polish, step_tolerance=posture_step_tolerance)
    stages, iterations = [], 0
    phases = [True, False] if posture is not None else [False]
    for regularised in phases:
        problem = Problem([VariableBlock("x", x, lower=lower, upper=upper)])
        for block, _ in blocks:
            problem.add_residual(block)
        if regularised:
            w = np.asarray(posture.weights, float)
            ref = np.asarray(posture.reference, float)
            problem.add_residual(FunctionBlock(["x"], len(w), lambda v: (w * (v - ref), [np.diag(w)])))
            if soft_targets:
                legs = sorted(soft_targets)
                pts = np.array([soft_targets[leg] for leg in legs])
                soft = _TermCache({"soft": lambda X, Q: foot_target_terms(robot, X, legs, pts, Q)})
                problem.add_residual(FunctionBlock(["x"], 3 * len(legs), soft.block(robot, "soft")), soft_weight)
        result = solve_lm(problem, regularise if regularised else polish)
        x = result.values["x"]
        iterations += result.iterations
        stages.append(f"{'posture' if regularised else 'polish'}: {result.status.value} "
                      f"({result.iterations} it, |h|={result.norm:.2e})")
    return _judge(robot, sdf, mode, x, blocks, targets, foot_tolerance, iterations, stages)


def _judge(robot, sdf, mode, x, blocks, targets, foot_tolerance, iterations, stages) -> IKResult:
    """Evaluate the raw constraint values at x and decide success with a reason."""
    X = x[None, :]
    foot = 0.0
    if mode.stance.any():
        foot = float(np.abs(stance_foot_terms(robot, X, mode)[0]).max())
    if targets:
        legs = sorted(targets)
        err = foot_target_terms(robot, X, legs, np.array([targets[leg] for leg in legs]))[0]
        foot = max(foot, float(np.abs(err).max()))
    com = float(com_terms(robot, X, mode)[0].max())
    coll = float(collision_terms(robot, X, mode, sdf)[0].max(initial=-np.inf)) if sdf is not None else -np.inf
    problems = []
    if foot > foot_tolerance:
        problems.append(f"foot error {foot * 1e3:.2f} mm > {foot_tolerance * 1e3:.2f} mm")
    if com > 1e-6:
        problems.append(f"CoM {com * 1e3:.1f} mm short of the support margin")
    if coll > 1e-6:
        problems.append(f"a collision sphere {coll * 1e3:.1f} mm inside the clearance margin")
    q = robot.from_vector(X)[0]
    return IKResult(x=x, q=q, success=not problems, reason="; ".join(problems), foot_error=foot,
                    com_violation=com, collision_violation=coll, iterations=iterations, stages=stages)
