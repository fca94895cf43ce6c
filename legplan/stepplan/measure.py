"""Independent judgement of a planned step: dense re-sampling checked with pinocchio FK + FCL.

The planner samples its constraints at N points with its own residual code (terrain distance,
batch kinematics); here the finished path is re-sampled at ≥ 1000 parameters and every
configuration is judged by `legplan.validate.judge` (pinocchio frame placements, FCL distance to
the triangulated heightmap), which shares no code with the residuals. A step keeps its success only
when every constraint is kept on the dense samples (`judge`). Path quality: the terms of eq. (5),
∫‖π^(k)‖ dt for k = 1, 2, 3, from the control points (x-space: metres and radians mixed).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from legplan.geometry.bezier import derivative_norm_integrals, evaluate
from legplan.validate.judge import CONSTRAINTS, Requirements, failures, shortfalls


@dataclass(frozen=True)
class DenseCheck:
    """Worst values over the dense samples (units: m, m, rad; shortfalls as `legplan.validate.judge`:
    the clearance shortfall is required clearance − clearance, so 2 cm − the smallest clearance of a
    body or leg sphere when that is the worst)."""

    foot_slip: float  # largest stance-foot distance from its foothold
    com_margin: float  # smallest signed CoM distance to the support-polygon edges (< 0: outside)
    joint_excess: float  # largest excursion beyond a joint limit (0 inside)
    shortfall_foot_slip: float  # worst shortfall per constraint: ≤ 0 kept, > 0 failed
    shortfall_com_margin: float
    shortfall_clearance: float
    shortfall_joint_limits: float
    length: float  # ∫‖π'‖ dt
    roughness2: float  # ∫‖π''‖ dt
    roughness3: float  # ∫‖π'''‖ dt

    def as_dict(self) -> dict[str, float]:
        return asdict(self)

    def shortfalls(self) -> dict[str, float]:
        return {name: getattr(self, f"shortfall_{name}") for name in CONSTRAINTS}


DENSE_UNITS = {"foot_slip": "m", "com_margin": "m", "joint_excess": "rad",
               **{f"shortfall_{name}": unit for name, unit in CONSTRAINTS.items()},
               "length": "", "roughness2": "", "roughness3": ""}


def requirements(params) -> Requirements:
    """What a step of a planner with these settings (`StepPlanParams` or the baseline's) must keep:
    stance feet within ε, the CoM margin, `clearance` for every sphere but the stance feet with the
    swing-foot ramp within `relax_radius` of the swing ends, joint limits; each inequality within
    the tolerance `judge_tolerance`."""
    return Requirements(foot_slip=params.epsilon, com_margin=params.com_margin, clearance=params.clearance,
                        foot_clearance=params.clearance, relax_radius=params.relax_radius,
                        tolerance=params.judge_tolerance)


def dense_check(robot, validator, control_points, stance, footholds, samples: int,
                required: Requirements) -> DenseCheck:
    """Judge the Bézier path of `control_points` (x-space) at `samples` uniform parameters.

    The constraints are judged by `check_path`; the quality terms are the exact eq. (5) integrals
    ∫‖π^(k)‖ dt, k = 1, 2, 3, of the Bézier curve.
    """
    t = np.linspace(0.0, 1.0, samples)
    quality = derivative_norm_integrals(control_points, orders=(1, 2, 3))
    return check_path(robot, validator, evaluate(control_points, t), stance, footholds, quality, required)


def check_path(robot, validator, X, stance, footholds, quality, required: Requirements) -> DenseCheck:
    """Judge the dense samples X (n, nx) (x-space, in path order) of any path between two footholds.

    `quality` holds the path's (length, roughness2, roughness3) terms of eq. (5), computed by the
    caller for its kind of path. The swing-foot ramp is measured from the first and last sample.
    """
    Q = robot.from_vector(np.asarray(X, float))
    worst, checks = shortfalls(validator, Q, stance, footholds, required, path=True)
    return DenseCheck(foot_slip=float(np.nan_to_num(checks.foot_slip, nan=0.0).max(initial=0.0)),
                      com_margin=float(checks.com_margin.min()),
                      joint_excess=float(checks.joint_excess.max(initial=0.0)),
                      **{f"shortfall_{k}": float(v.max()) for k, v in worst.items()},
                      length=float(quality[0]), roughness2=float(quality[1]), roughness3=float(quality[2]))


def judged(record: dict, check: DenseCheck, required: Requirements) -> dict:
    """`record` with its dense check; a planner success that misses a constraint on the dense samples
    becomes a failure naming the constraints."""
    record["dense"] = check.as_dict()
    missed = failures(check.shortfalls(), required)
    if record["success"] and missed:
        record["success"] = False
        record["reason"] = "dense re-check: " + "; ".join(missed)
    return record
