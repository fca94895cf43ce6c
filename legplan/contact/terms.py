"""Constraint terms of one contact mode, batched over configurations in the vector parametrization.

A configuration is the vector x = [p, ω, joints] of the Bézier paper eq. (1b) (`robot.to_vector`).
Every term maps a batch X (n, nx) to per-configuration values (n, m) and Jacobian blocks (n, m, nx)
(J_x = J_v @ robot.tangent_map(X)), so the Bézier step planner can chain them with Bernstein weights
at its samples and the IK (`legplan.contact.ik`) can use them at one configuration.

Conventions (Sec. II-B and eq. (4)): equality terms f(x) = 0 (kinematic constraint of the stance
feet); inequality terms g(x) <= 0 (stability, collisions, joint limits), which eq. (8b) turns into
residuals min(-g, 0), i.e. `HingeInequality` max(g, 0).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from legplan.geometry.polygon import ConvexPolygon, support_polygon


@dataclass(frozen=True)
class ContactMode:
    """What one step (or one configuration) must satisfy.

    `stance` (n_legs,) bool: legs whose feet must stay on `footholds` (n_legs, 3) (rows of swing legs
    are ignored). `support` (n_legs,) bool: legs whose footholds span the support polygon the CoM
    must stay inside (default: `stance`; the step generator passes the support of the adjacent
    motions). `com_margin` (m): required distance of the CoM to every polygon edge.
    `clearance` (m): required sphere clearance from the terrain; `foot_clearance` (m) applies to
    the foot spheres of swing legs (relaxed near the footholds, as in the paper's Sec. IV);
    stance-foot spheres are exempt (they touch their footholds).
    """

    stance: np.ndarray
    footholds: np.ndarray
    support: np.ndarray | None = None
    com_margin: float = 0.02
    clearance: float = 0.02
    foot_clearance: float = 0.0
    polygon: ConvexPolygon = field(init=False, repr=False)

    def __post_init__(self):
        stance = np.asarray(self.stance, bool)
        support = stance if self.support is None else np.asarray(self.support, bool)
        footholds = np.asarray(self.footholds, float)
        object.__setattr__(self, "stance", stance)
        object.__setattr__(self, "support", support)
        object.__setattr__(self, "footholds", footholds)
        object.__setattr__(self, "polygon", support_polygon(footholds[support]))


def _jac_x(robot, X: np.ndarray, jac_v: np.ndarray) -> np.ndarray:
    """Jacobians w.r.t. the tangent v (n, ..., nv) mapped to the vector x (n, ..., nx)."""
    tangent = robot.tangent_map(X)
    if tangent.shape[1] != tangent.shape[2] or tangent.shape[1] < 6:  # no columns (values only), or no base
        return np.einsum("n...v,nvx->n...x", jac_v, tangent)
    return block_tangent_product(jac_v, tangent)


def block_tangent_product(jac_v: np.ndarray, tangent: np.ndarray) -> np.ndarray:
    """J_v @ T for T = blockdiag(A, B, I) (n, nv, nv), the tangent map of `RobotModel.tangent_map`:
    the base's two 3×3 blocks multiplied out, the joint columns copied. Each entry is summed in the
    order `einsum("n...v,nvx->n...x")` sums it (the other terms are exact zeros), so the numbers are
    the dense product's at a fraction of its cost."""
    out = np.empty(jac_v.shape)
    lead = (slice(None),) + (None,) * (jac_v.ndim - 2)
    for lo in (0, 3):
        block = tangent[:, lo:lo + 3, lo:lo + 3][lead]                   # (n, 1, ..., 3, 3)
        col = [jac_v[..., lo + k, None] * block[..., k, :] for k in range(3)]
        out[..., lo:lo + 3] = (col[0] + col[1]) + col[2]
    out[..., 6:] = jac_v[..., 6:]
    return out


def stance_foot_terms(robot, X, mode: ContactMode, Q=None):
    """Equality f = foot position - foothold of each stance leg: values (n, 3k), Jacobians (n, 3k, nx)."""
    X = np.atleast_2d(X)
    Q = robot.from_vector(X) if Q is None else Q
    legs = np.flatnonzero(mode.stance)
    feet = robot.foot_positions(Q)[:, legs]
    values = (feet - mode.footholds[legs]).reshape(len(X), -1)
    jac = _jac_x(robot, X, robot.foot_jacobians(Q)[:, legs]).reshape(len(X), 3 * len(legs), -1)
    return values, jac


def foot_target_terms(robot, X, legs, targets, Q=None):
    """Equality f = foot position - target for the given legs (e.g. a lifted swing foot)."""
    X = np.atleast_2d(X)
    Q = robot.from_vector(X) if Q is None else Q
    legs = np.asarray(legs, int)
    values = (robot.foot_positions(Q)[:, legs] - np.asarray(targets, float)).reshape(len(X), -1)
    jac = _jac_x(robot, X, robot.foot_jacobians(Q)[:, legs]).reshape(len(X), 3 * len(legs), -1)
    return values, jac


def com_terms(robot, X, mode: ContactMode, Q=None):
    """Inequality g = com_margin - (b_i - a_i . com_xy) <= 0 per polygon edge i: (n, h), (n, h, nx)."""
    X = np.atleast_2d(X)
    Q = robot.from_vector(X) if Q is None else Q
    poly = mode.polygon
    com = robot.com(Q)
    values = mode.com_margin - poly.margins(com[:, :2])
    jac_xy = _jac_x(robot, X, robot.com_jacobian(Q))[:, :2]
    return values, np.einsum("hk,nkx->nhx", poly.A, jac_xy)


def sphere_margins(robot, mode: ContactMode) -> np.ndarray:
    """Required clearance per collision sphere; NaN for the exempt stance-foot spheres."""
    spheres = robot.spheres
    margins = np.full(len(spheres.radii), mode.clearance, dtype=float)
    legs = np.asarray(spheres.leg_index)
    is_foot = np.asarray(spheres.is_foot, bool)
    on_leg = legs >= 0
    stance_leg = np.zeros(len(legs), bool)
    stance_leg[on_leg] = mode.stance[legs[on_leg]]
    margins[is_foot & ~stance_leg] = mode.foot_clearance
    margins[is_foot & stance_leg] = np.nan
    return margins


def swing_foot_margin(distance, radii, clearance: float, epsilon: float, relax_radius: float):
    """Required clearance of swing-foot spheres near their lift-off and touch-down positions.

    A sphere of radius r whose centre lies `distance` from the nearer of its two end positions must
    keep a clearance ramping linearly from −(r + ε) at the end (the tip may touch the foothold,
    within the foot tolerance ε) to `clearance` at distance ≥ `relax_radius` (paper Sec. IV: "2 cm
    collision margin locally relaxed around the footholds"). Returns (margin, d margin / d distance).
    """
    distance = np.asarray(distance, float)
    floor = -(np.asarray(radii, float) + epsilon)
    span = clearance - floor
    ramp = np.clip(distance / relax_radius, 0.0, 1.0)
    slope = span / relax_radius * ((distance > 0) & (distance < relax_radius))
    return floor + span * ramp, slope


def nearest_end(centres, ends, direction: bool = False):
    """Distance (n, k) of sphere centres (n, k, 3) to the nearer of their end positions (2, k, 3);
    with `direction`, (distance, unit vector (n, k, 3) from that end to the centre)."""
    diff = np.asarray(centres)[None] - np.asarray(ends)[:, None]     # (2, n, k, 3)
    dist = np.sqrt(np.add.reduce(diff * diff, axis=-1))  # numpy's norm along the last axis, without its checks
    if not direction:
        return dist.min(axis=0)
    nearest = np.argmin(dist, axis=0)
    d = np.take_along_axis(dist, nearest[None], 0)[0]
    unit = np.take_along_axis(diff, nearest[None, ..., None], 0)[0] / np.maximum(d, 1e-12)[..., None]
    return d, unit


def collision_reach(robot, clearance: float) -> float:
    """A terrain distance beyond every one at which a collision row can be active (clearance +
    largest sphere radius, + 1 mm so that rounding leaves a row at a saturated distance inactive): a
    terrain distance exact up to this and saturated above it makes every row of `collision_terms` exact."""
    return float(clearance + np.max(robot.spheres.radii, initial=0.0) + 1e-3)


def collision_terms(robot, X, mode: ContactMode, sdf, Q=None):
    """Inequality g = margin - (sdf(c) - radius) <= 0 per checked sphere: (n, s), (n, s, nx).

    `sdf` is any terrain distance with `value_and_gradient(points)`: the exact column distance
    (`legplan.terrain.ColumnDistance`) or the trilinear SDF lookup.
    """
    X = np.atleast_2d(X)
    Q = robot.from_vector(X) if Q is None else Q
    margins = sphere_margins(robot, mode)
    checked = np.flatnonzero(~np.isnan(margins))
    centres = robot.sphere_centres(Q)[:, checked]
    n, s = centres.shape[:2]
    dist, grad = sdf.value_and_gradient(centres.reshape(-1, 3))
    values = margins[checked] - (dist.reshape(n, s) - robot.spheres.radii[checked])
    jac_c = _jac_x(robot, X, robot.sphere_jacobians(Q)[:, checked])
    return values, -np.einsum("nsk,nskx->nsx", grad.reshape(n, s, 3), jac_c)


def joint_limit_terms(robot, X):
    """Inequality g = [x_j - upper, lower - x_j] <= 0 on the joint entries of x: (n, 2J), (n, 2J, nx)."""
    X = np.atleast_2d(X)
    n, nx = X.shape
    nj = robot.n_joints
    joints = X[:, nx - nj:]
    values = np.concatenate([joints - robot.upper, robot.lower - joints], axis=1)
    eye = np.zeros((2 * nj, nx))
    eye[np.arange(nj), nx - nj + np.arange(nj)] = 1.0
    eye[nj + np.arange(nj), nx - nj + np.arange(nj)] = -1.0
    return values, np.broadcast_to(eye, (n, 2 * nj, nx)).copy()
