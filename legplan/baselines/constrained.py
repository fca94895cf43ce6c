"""Constrained sampling-based planning of one step with OMPL (Kingston, Moll & Kavraki).

The configuration space is the robot's vector parametrization x = [p, ω, joints] ∈ R^nv
(`robot.to_vector`, Bézier paper eq. (1b)); the motion must stay on the implicit manifold
F(x) = 0 where F stacks `foot position − foothold` of every stance leg (3 rows per leg, the
kinematic constraint of eq. (4a)). `StanceConstraint` gives OMPL F and its Jacobian from the robot
layer's batch kinematics (J_x = J_v · tangent_map, one pinocchio pass serves both calls) and the
planner explores the manifold through one of OMPL's constrained state spaces:

* "projected": samples and interpolation steps are projected back by Newton iterations;
* "atlas": a lazily built atlas of tangent-space charts;
* "tangent": the tangent bundle (charts, lazy projection).

The state validity checker, the rest of the problem and the sampler's configuration are the
caller's (`plan_constrained`), so the same core runs on a real robot (`legplan.baselines.step`) and
on analytic test robots.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from legplan.baselines.names import CONSTRAINED_SPACES
from legplan.baselines.runtime import ompl_modules, real_vector_bounds, seed_ompl, state_values

log = logging.getLogger(__name__)

_ob = ompl_modules().ob
_og = ompl_modules().og


class StanceConstraint(_ob.Constraint):
    """F(x) = (foot_l(x) − foothold_l) for the stance legs l, stacked (3k rows), on x ∈ R^nv."""

    def __init__(self, robot, stance, footholds, tolerance: float):
        self.robot = robot
        self.legs = np.flatnonzero(np.asarray(stance, bool))
        self.targets = np.asarray(footholds, float)[self.legs]
        super().__init__(robot.nv, 3 * len(self.legs), tolerance)

    def _kinematics(self, x):
        X = np.asarray(x, float)[None]
        return X, self.robot.kinematics(self.robot.from_vector(X), jacobians=True)

    def function(self, x, out):
        _, kin = self._kinematics(x)
        out[:] = (kin.foot_positions[0, self.legs] - self.targets).reshape(-1)

    def jacobian(self, x, out):
        X, kin = self._kinematics(x)  # same x as the preceding `function` call: a cache hit
        jac = kin.foot_jacobians[0, self.legs].reshape(3 * len(self.legs), -1)
        out[:, :] = jac @ self.robot.tangent_map(X)[0]

    def residual(self, x) -> float:
        """Largest stance-foot distance from its foothold at x, m."""
        _, kin = self._kinematics(x)
        return float(np.linalg.norm(kin.foot_positions[0, self.legs] - self.targets, axis=1).max(initial=0.0))


@dataclass(frozen=True)
class ConstrainedResult:
    """One constrained query: `waypoints` (k, n) on the manifold (start and goal included) or None."""

    success: bool
    reason: str
    status: str
    waypoints: np.ndarray | None
    solve_seconds: float  # OMPL solve() wall time (to the first solution for RRT-Connect)
    seconds: float  # everything: spaces, solve, simplification, interpolation


def plan_constrained(constraint, valid: Callable[[np.ndarray], bool], x_start, x_goal, low, high, *,
                     space: str = "atlas", time_budget: float = 10.0, seed: int = 0, delta: float = 0.05,
                     simplify_time: float = 0.0, waypoints: int = 100) -> ConstrainedResult:
    """RRT-Connect from `x_start` to `x_goal` on the manifold of `constraint` (an `ob.Constraint`).

    `valid(x)` judges a configuration; `low`/`high` bound the ambient space; `delta` is the
    constrained space's step (ambient units); the solution is shortcut for at most `simplify_time`
    seconds (0: no simplification) and interpolated along the manifold by OMPL's
    `PathGeometric.interpolate(waypoints)` (on a constrained space it stops at the discrete
    geodesic's resolution `delta`, so there may be fewer states). Start and goal off the manifold by more than the tolerance are projected first.
    """
    ob, og = _ob, _og
    if space not in CONSTRAINED_SPACES:
        raise ValueError(f"space must be one of {CONSTRAINED_SPACES}, got {space!r}")
    t0 = time.perf_counter()
    seed_ompl(seed)
    dim = len(x_start)
    ambient = ob.RealVectorStateSpace(dim)
    ambient.setBounds(real_vector_bounds(low, high))
    kind = {"projected": ob.ProjectedStateSpace, "atlas": ob.AtlasStateSpace,
            "tangent": ob.TangentBundleStateSpace}[space]
    css = kind(ambient, constraint)
    si = (ob.TangentBundleSpaceInformation if space == "tangent" else ob.ConstrainedSpaceInformation)(css)
    si.setStateValidityChecker(lambda state: bool(valid(np.array(state_values(state, dim)))))
    css.setDelta(delta)
    css.setup()
    si.setup()
    ends = []
    for name, x in (("start", x_start), ("goal", x_goal)):
        state = css.allocState()
        state.copy([float(v) for v in x])
        if not constraint.isSatisfied(state) and not constraint.project(state):
            return _failed(f"{name} is off the stance manifold and could not be projected", "INVALID_START"
                           if name == "start" else "INVALID_GOAL", t0)
        if space != "projected":
            css.anchorChart(state)
        ends.append(state)
    pdef = ob.ProblemDefinition(si)
    pdef.setStartAndGoalStates(ends[0], ends[1])
    planner = og.RRTConnect(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    t_solve = time.perf_counter()
    status = planner.solve(ob.timedPlannerTerminationCondition(float(time_budget)))
    solve_seconds = time.perf_counter() - t_solve
    name = status.asString()
    if not pdef.hasExactSolution():
        reason = f"OMPL RRT-Connect ({space}): {name} within the {time_budget:g} s budget"
        return ConstrainedResult(False, reason, name, None, solve_seconds, time.perf_counter() - t0)
    path = pdef.getSolutionPath()
    if simplify_time > 0:
        og.PathSimplifier(si).simplify(path, float(simplify_time))
    path.interpolate(int(waypoints))
    X = np.array([state_values(s, dim) for s in path.getStates()])
    log.debug("%s: %d states after %.3f s", name, len(X), time.perf_counter() - t0)
    return ConstrainedResult(True, "", name, X, solve_seconds, time.perf_counter() - t0)


def _failed(reason: str, status: str, t0: float) -> ConstrainedResult:
    return ConstrainedResult(False, reason, status, None, 0.0, time.perf_counter() - t0)
