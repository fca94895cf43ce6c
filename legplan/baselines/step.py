"""OMPL baseline of `legplan step plan`: constrained RRT-Connect per consecutive pair of a steps.h5.

For the pair (q_i, q_{i+1}) the legs in stance at both ends on the same foothold
(`legplan.stepplan.motion_stance`) define the manifold (`StanceConstraint`); a configuration is
valid when it meets the inequality constraints of the Bézier planner itself — CoM inside the
support polygon with `com_margin`, every checked sphere `clearance` clear of the SDF (swing-foot
margin relaxed near its footholds) and the joint limits — evaluated by the step planner's own
`SampleConstraints` (the equality rows are the manifold and are not part of validity), so both
planners solve the same problem (like the Bézier planner, neither end configuration is checked). The start and goal vectors are those of the Bézier planner
(`path_vectors`, end rotation vector unwrapped towards the start).

The result is a piecewise-linear x-space path through the manifold states of the interpolated
OMPL solution. It is judged like a Bézier step, by the same rules (`legplan.stepplan.measure.check_path`
and `judged`): re-sampled at `dense_samples` points uniform in x-space arc length and checked by the
independent validator; a path that misses a constraint there is a failure naming it. Validity and
planning use the exact terrain distance (`legplan.terrain.ColumnDistance`), as the Bézier planner.
Quality terms of eq. (5) with t ∈ [0, 1] proportional to arc length, by finite differences of
the dense samples (spacing h = 1/(n − 1)): length = Σ‖Δx‖ (a sample chord cuts each corner, so
it is the waypoint polyline's length to ~1e-4 relative at 1000 samples), roughness2 = Σ‖Δ²x‖/h (the
sum of the velocity jumps at the corners, independent of h once h is below the waypoint spacing),
roughness3 = Σ‖Δ³x‖/h² (∫‖π'''‖ is unbounded for a polyline: the value grows as 1/h and is
reported for completeness only, at the stated dense_samples).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from legplan.baselines.names import CONSTRAINED_SPACES
from legplan.geometry.polyline import arc_length, resample_by_arc_length
from legplan.parameters import Parameters, inherit, param
from legplan.stepplan.batch import StepWorker, plan_pairs
from legplan.stepplan.params import StepPlanParams

log = logging.getLogger(__name__)

END_EXEMPTION = 1e-3  # m | rad, per coordinate of x (see `step_validity`)


@dataclass(frozen=True)
class StepBaselineParams(Parameters):
    what = "step baseline"

    time_budget: float = param(10.0, "(0, 86400]", doc="s of OMPL solve() per step")
    space: str = param("atlas", CONSTRAINED_SPACES)
    seed: int = param(0, "[0, 4294967295]", doc="step i is planned with OMPL seed `seed + i`")
    tolerance: float = param(1e-4, "(0, inf)", doc="m, constraint tolerance of the projection (OMPL default)")
    delta: float = param(0.02, "(0, inf)", doc="constrained-space step in x units (m | rad)")
    simplify_time: float = param(0.0, "[0, 86400]", doc="s of path shortcutting after the first solution (0: none)")
    waypoints: int = param(100, "[2, 1000000]",
                           doc="states asked of the interpolated solution (capped by the geodesic step `delta`)")
    position_margin: float = param(0.1, "[0, 100]", doc="m, ambient bounds around the start/goal base positions")
    rotation_margin: float = param(0.5, "[0, 6.3]", doc="rad, ambient bounds around the start/goal rotation vectors")
    # the step planner's constraint settings, for the same problem:
    epsilon: float = inherit(StepPlanParams, "epsilon")
    slack_fraction: float = inherit(StepPlanParams, "slack_fraction")
    clearance: float = inherit(StepPlanParams, "clearance")
    relax_radius: float = inherit(StepPlanParams, "relax_radius")
    com_margin: float = inherit(StepPlanParams, "com_margin")
    dense_samples: int = inherit(StepPlanParams, "dense_samples", range="[4, 10000000]")  # third differences
    judge_tolerance: float = inherit(StepPlanParams, "judge_tolerance")

    @property
    def sample_clearance(self) -> float:
        """Clearance of a valid state: `clearance` itself (no sample headroom: OMPL checks its motions)."""
        return self.clearance

    @property
    def planner(self) -> str:
        return f"ompl-rrtconnect-{self.space}"


def polyline_samples(waypoints: np.ndarray, count: int) -> np.ndarray:
    """`count` points (count, n) uniform in arc length along the polyline through `waypoints` (k, n)."""
    W = np.asarray(waypoints, float)
    total = arc_length(W)[-1]
    if total <= 0.0:
        return np.repeat(W[:1], count, axis=0)
    return resample_by_arc_length(W, np.linspace(0.0, total, count))[0]


def polyline_quality(X: np.ndarray) -> tuple[float, float, float]:
    """(length, roughness2, roughness3) of eq. (5) by finite differences of dense samples X (n, nx),
    uniform in t ∈ [0, 1] (see the module docstring for what they mean on a polyline)."""
    h = 1.0 / (len(X) - 1)
    terms = [float(np.linalg.norm(np.diff(X, k, axis=0), axis=1).sum() * h / h ** k) for k in (1, 2, 3)]
    return terms[0], terms[1], terms[2]


def ambient_bounds(robot, x0, x1, params: StepBaselineParams) -> tuple[np.ndarray, np.ndarray]:
    """Box of the sampling space: base position and rotation vector around the two ends, joint limits
    widened to the ends' joints ± `END_EXEMPTION`: a sequence's configuration may exceed a limit by its
    IK tolerance (and its projection onto the manifold move a little further), and OMPL rejects a
    start or goal outside the bounds; validity still enforces the limits everywhere else."""
    ends = np.stack([x0, x1])
    low = np.r_[ends[:, :3].min(0) - params.position_margin, ends[:, 3:6].min(0) - params.rotation_margin,
                np.minimum(robot.lower, ends[:, 6:].min(0) - END_EXEMPTION)]
    high = np.r_[ends[:, :3].max(0) + params.position_margin, ends[:, 3:6].max(0) + params.rotation_margin,
                 np.maximum(robot.upper, ends[:, 6:].max(0) + END_EXEMPTION)]
    return low, high


def step_validity(robot, sdf, x0, x1, stance, footholds, params: StepBaselineParams) -> Callable[[np.ndarray], bool]:
    """valid(x): the Bézier planner's inequality rows (CoM, clearance, joint limits) all met at x.

    The two given end configurations are exempt (within `END_EXEMPTION` per coordinate, which
    covers their projection onto the manifold): the Bézier planner fixes its end control points and
    samples only t_i = i/N, 0 < i < N (eq. (10)), so it never checks them either — and a sequence's
    configuration may sit a little inside the 2 cm margin (e.g. a swing leg's shin near an obstacle
    at touch-down), which would make OMPL reject the query outright.
    """
    from legplan.stepplan.block import SampleConstraints
    from legplan.stepplan.planner import contact_mode

    ends = robot.sphere_centres(robot.from_vector(np.stack([x0, x1])))
    constraints = SampleConstraints(robot, sdf, contact_mode(stance, footholds, params),
                                    params.slack_fraction * params.epsilon, swing_ends=ends,
                                    relax_radius=params.relax_radius)
    first = 4 * len(constraints.legs)  # stance-foot equality (3 per leg) and slack-bound rows come first
    slack = np.zeros((1, constraints.slack_size))
    ends = np.stack([x0, x1])

    def valid(x: np.ndarray) -> bool:
        if np.abs(ends - x).max(axis=1).min() <= END_EXEMPTION:
            return True
        rows = constraints.evaluate(x[None], slack, False)[0]
        return bool(np.all(rows[0, first:] <= 0.0))

    return valid


class StepBaselineWorker(StepWorker):
    """The step planner's worker (robot, exact terrain distance, independent validator, loaded once)
    whose `plan` plans one pair with OMPL instead, judged by the same rules."""

    def plan(self, index: int, q_start, q_end, stance, footholds) -> dict:
        """Plan and judge one step; never raises (a failure is a record with a reason)."""
        from legplan.baselines.constrained import StanceConstraint, plan_constrained
        from legplan.stepplan.measure import check_path, judged
        from legplan.stepplan.planner import path_vectors

        p, robot = self.params, self.robot
        t0 = time.perf_counter()
        footholds = np.nan_to_num(np.asarray(footholds, float), nan=0.0)
        record = {"index": index, "q_start": np.asarray(q_start), "q_end": np.asarray(q_end),
                  "stance": np.asarray(stance, bool), "footholds": footholds}
        try:
            x0, x1 = path_vectors(robot, np.asarray(q_start, float), np.asarray(q_end, float))
            valid = step_validity(robot, self.distance, x0, x1, stance, footholds, p)
            constraint = StanceConstraint(robot, stance, footholds, p.tolerance)
            low, high = ambient_bounds(robot, x0, x1, p)
            result = plan_constrained(constraint, valid, x0, x1, low, high, space=p.space,
                                      time_budget=p.time_budget, seed=p.seed + int(index), delta=p.delta,
                                      simplify_time=p.simplify_time, waypoints=p.waypoints)
        except Exception as exc:  # a bad pair must not stop the batch
            log.debug("step %d raised", index, exc_info=True)
            record.update(success=False, reason=f"{type(exc).__name__}: {exc}", seconds=time.perf_counter() - t0)
            return record
        record.update(success=result.success, reason=result.reason, seconds=result.seconds,
                      attrs={"planner": p.planner, "ompl_status": result.status},
                      timings={"ompl_solve": result.solve_seconds, "total": result.seconds})
        if result.waypoints is not None:
            record["waypoints"] = result.waypoints
            dense = polyline_samples(result.waypoints, p.dense_samples)
            check = check_path(robot, self.validator, dense, stance, footholds, polyline_quality(dense),
                               self.required)
            judged(record, check, self.required)
        return record


def plan_sequence_baseline(seq, map_path, params: StepBaselineParams, indices: Sequence[int],
                           progress: Callable[[int, int, str], None] | None = None) -> list[dict]:
    """Plan pairs (q_i, q_{i+1}) for i in `indices` of a `StepSequence` in this process (each step
    reseeds OMPL, so any worker gives the same path); records in index order, for
    `legplan.stepplan.write_motion`."""
    return plan_pairs(StepBaselineWorker(seq.robot, str(map_path), params), seq, indices, progress)
