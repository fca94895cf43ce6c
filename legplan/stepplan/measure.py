"""Independent judgement of a planned step: dense re-sampling checked with pinocchio FK + FCL.

The planner samples its constraints at N points with its own residual code (SDF, batch kinematics);
here the finished curve is re-sampled at ≥ 1000 parameters and every configuration is checked by
`legplan.validate.Validator` (pinocchio frame placements, FCL distance to the triangulated
heightmap), which shares no code with the residuals. Path quality: the terms of eq. (5),
∫‖π^(k)‖ dt for k = 1, 2, 3, from the control points (x-space: metres and radians mixed).
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from legplan.geometry.bezier import derivative_norm_integrals, evaluate


@dataclass(frozen=True)
class DenseCheck:
    """Worst values over the dense samples (units: m, m, m, rad)."""

    foot_slip: float  # largest stance-foot distance from its foothold
    com_margin: float  # smallest signed CoM distance to the support-polygon edges (< 0: outside)
    clearance: float  # smallest sphere-terrain clearance (< 0: collision); see `dense_check`
    swing_foot_tip: float  # smallest terrain distance of a swing-foot sphere centre, whole path
    joint_excess: float  # largest excursion beyond a joint limit (0 inside)
    length: float  # ∫‖π'‖ dt
    roughness2: float  # ∫‖π''‖ dt
    roughness3: float  # ∫‖π'''‖ dt

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


DENSE_UNITS = {"foot_slip": "m", "com_margin": "m", "clearance": "m", "swing_foot_tip": "m", "joint_excess": "rad",
               "length": "", "roughness2": "", "roughness3": ""}


def dense_check(robot, validator, control_points, stance, footholds, samples: int = 1000,
                relax_radius: float = 0.05) -> DenseCheck:
    """Check the Bézier path of `control_points` (x-space) at `samples` uniform parameters.

    The constraints are judged by `check_path`; the quality terms are the exact eq. (5) integrals
    ∫‖π^(k)‖ dt, k = 1, 2, 3, of the Bézier curve.
    """
    t = np.linspace(0.0, 1.0, samples)
    quality = derivative_norm_integrals(control_points, orders=(1, 2, 3))
    return check_path(robot, validator, evaluate(control_points, t), stance, footholds, quality, relax_radius)


def check_path(robot, validator, X, stance, footholds, quality, relax_radius: float = 0.05) -> DenseCheck:
    """Judge the dense samples X (n, nx) (x-space, in path order) of any path between two footholds.

    `quality` holds the path's (length, roughness2, roughness3) terms of eq. (5), computed by the
    caller for its kind of path.

    Clearance is the FCL surface distance of each sphere centre minus its radius, over all spheres
    except stance feet and except swing-foot spheres within `relax_radius` of their lift-off or
    touch-down position (the first and last sample, where the planner lets the foot reach the
    terrain); there the swing foot is judged by `swing_foot_tip`, the surface distance of its
    sphere centre (the foot point for robots whose foot sphere sits on the foot frame) — ≥ −ε
    means it never sinks into the terrain.
    """
    Q = robot.from_vector(np.asarray(X, float))
    n = len(Q)
    stance = np.asarray(stance, bool)
    checks = validator.check(Q, np.broadcast_to(stance, (n, len(stance))),
                             np.broadcast_to(np.asarray(footholds, float), (n,) + np.shape(footholds)))
    slip = np.nan_to_num(checks.foot_slip, nan=0.0)
    _, centres, _ = validator.kinematics(Q)
    spheres = robot.spheres
    legs = np.asarray(spheres.leg_index)
    on_stance_leg = np.where(legs >= 0, stance[np.maximum(legs, 0)], False)
    is_foot = np.asarray(spheres.is_foot, bool)
    checked = np.broadcast_to(~(is_foot & on_stance_leg), (n, len(legs))).copy()
    swing_feet = np.flatnonzero(is_foot & ~on_stance_leg & (legs >= 0))
    tip = np.inf
    if swing_feet.size:
        tip = float(validator.surface.signed_distance(centres[:, swing_feet].reshape(-1, 3)).min())
        ends = centres[[0, -1]][:, swing_feet]
        near = np.linalg.norm(centres[:, None, swing_feet] - ends[None], axis=-1).min(axis=1) < relax_radius
        checked[:, swing_feet] &= ~near
    gap = validator.surface.signed_distance(centres[checked]) - np.asarray(spheres.radii)[np.nonzero(checked)[1]]
    return DenseCheck(foot_slip=float(slip.max(initial=0.0)), com_margin=float(checks.com_margin.min()),
                      clearance=float(gap.min(initial=np.inf)), swing_foot_tip=tip,
                      joint_excess=float(checks.joint_excess.max(initial=0.0)),
                      length=float(quality[0]), roughness2=float(quality[1]), roughness3=float(quality[2]))
