"""Residual blocks of the TEB objective R(B) = Σ_k γ_k R_k(B) of eq. (24), on the sparse LM core.

Every block reads the flat pose vector `poses` (3n: x_0, y_0, θ_0, x_1, …) and, where needed, the
interval vector `dt` (n − 1), and returns its values with analytic sparse Jacobian blocks (COO with
a fixed pattern, so CHOLMOD's analysis is reused across iterations). Blocks that express limits
return the limited quantity itself; `legplan.solve.IntervalPenalty` turns it into the TEB penalty.

* `VelocityBlock`      — (v_x, v_y, ω) per interval, eqs. (21)–(23)
* `AccelerationBlock`  — (a_x, a_y, α) between intervals, eq. (23), plus start/goal velocity rows
* `TimeBlock`          — ΔT_i (time optimality)
* `PathBlock`          — p_i − nearest point of the global path (attraction)
* `ClearanceBlock`     — l(p_i), distance to the nearest obstacle (repulsion via a lower bound)
* `ViaPointBlock`      — p_k − via point (and θ_k − heading) for the pose assigned to each via point
* `YawChangeBlock`     — Δθ_i, the paper's yaw-change penalty (Sec. IV)
* `NonholonomicBlock`  — (cos θ_i + cos θ_{i+1}) Δy_i − (sin θ_i + sin θ_{i+1}) Δx_i, the
  differential-drive kinematics residual of [19] (lateral velocity forced to zero)
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sp

from legplan.nav.teb.band import interval_accelerations, interval_velocities, wrap_angle
from legplan.nav.teb.distance import DistanceField
from legplan.solve import ResidualBlock

POSES, DT = "poses", "dt"


def scatter(shape: tuple[int, int], pieces) -> sp.coo_matrix:
    """COO matrix from dense pieces (row0 (m,), col0 (m,), values (m, r, c)); explicit zeros kept."""
    rows, cols, vals = [], [], []
    for row0, col0, values in pieces:
        values = np.asarray(values, float)
        if values.ndim == 2:
            values = values[:, :, None]
        m, r, c = values.shape
        rows.append(np.broadcast_to(np.asarray(row0)[:, None, None] + np.arange(r)[None, :, None], (m, r, c)).ravel())
        cols.append(np.broadcast_to(np.asarray(col0)[:, None, None] + np.arange(c)[None, None, :], (m, r, c)).ravel())
        vals.append(values.ravel())
    return sp.coo_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=shape)


class VelocityBlock(ResidualBlock):
    """Body-frame (v_x, v_y, ω) of every interval (rows 3i … 3i + 2), eq. (23)."""

    def __init__(self, n: int):
        self.n = n
        self.variables = (POSES, DT)
        self.size = 3 * (n - 1)

    def evaluate(self, values, jacobians):
        poses, dt = values[0].reshape(-1, 3), values[1]
        v, jv = interval_velocities(poses, dt)
        if not jacobians:
            return v.ravel(), None
        m = self.n - 1
        rows = 3 * np.arange(m)
        jp = scatter((self.size, 3 * self.n), [(rows, rows, jv.d_start), (rows, rows + 3, jv.d_end)])
        jt = scatter((self.size, m), [(rows, np.arange(m), jv.d_dt)])
        return v.ravel(), [jp, jt]


class AccelerationBlock(ResidualBlock):
    """(a_x, a_y, α) of eq. (23) for consecutive intervals, then optionally 3 rows for the start,
    (v_0 − v_start)/ΔT_0, and 3 for the goal, (v_goal − v_{n−2})/ΔT_{n−2} (body-frame velocities)."""

    def __init__(self, n: int, start_velocity=None, goal_velocity=None):
        self.n = n
        self.variables = (POSES, DT)
        self.start_velocity = None if start_velocity is None else np.asarray(start_velocity, float).reshape(3)
        self.goal_velocity = None if goal_velocity is None else np.asarray(goal_velocity, float).reshape(3)
        self.inner = 3 * max(n - 2, 0)
        self.size = self.inner + 3 * (self.start_velocity is not None) + 3 * (self.goal_velocity is not None)

    def evaluate(self, values, jacobians):
        poses, dt = values[0].reshape(-1, 3), values[1]
        parts, pose_pieces, dt_pieces = [], [], []
        row = 0
        if self.n >= 3:
            a, ja = interval_accelerations(poses, dt)
            parts.append(a.ravel())
            if jacobians:
                m = self.n - 2
                rows, cols = 3 * np.arange(m), 3 * np.arange(m)
                pose_pieces += [(rows, cols, ja.d_pose0), (rows, cols + 3, ja.d_pose1), (rows, cols + 6, ja.d_pose2)]
                dt_pieces += [(rows, np.arange(m), ja.d_dt0), (rows, np.arange(m) + 1, ja.d_dt1)]
            row = self.inner
        if self.start_velocity is not None or self.goal_velocity is not None:
            v, jv = interval_velocities(poses, dt)
        for boundary, k, sign in ((self.start_velocity, 0, 1.0), (self.goal_velocity, self.n - 2, -1.0)):
            if boundary is None:
                continue
            inv = 1.0 / dt[k]
            acc = sign * (v[k] - boundary) * inv
            parts.append(acc)
            if jacobians:
                r0 = np.array([row])
                pose_pieces += [(r0, [3 * k], sign * inv * jv.d_start[k:k + 1]),
                                (r0, [3 * k + 3], sign * inv * jv.d_end[k:k + 1])]
                dt_pieces.append((r0, [k], (sign * inv * jv.d_dt[k] - acc * inv)[None]))
            row += 3
        r = np.concatenate(parts) if parts else np.zeros(0)
        if not jacobians:
            return r, None
        return r, [scatter((self.size, 3 * self.n), pose_pieces), scatter((self.size, self.n - 1), dt_pieces)]


class TimeBlock(ResidualBlock):
    """r_i = ΔT_i: the time-optimality term (its square sums to Σ ΔT_i²)."""

    def __init__(self, n: int):
        self.variables = (DT,)
        self.size = n - 1

    def evaluate(self, values, jacobians):
        return values[0].copy(), ([sp.identity(self.size, format="coo")] if jacobians else None)


class PathBlock(ResidualBlock):
    """r_i = p_i − c_i with c_i the nearest point of the global path polyline (attraction).

    Pose i searches only the `width` segments starting at `first[i]` (a window of the path around
    the pose's own part of it), so a path that folds back does not capture the wrong stretch.
    The Jacobian is I − t tᵀ when c_i lies inside a segment of unit direction t, I at a vertex.
    """

    def __init__(self, n: int, path: np.ndarray, first: np.ndarray, width: int):
        self.n = n
        self.variables = (POSES,)
        self.size = 2 * n
        self.path = np.asarray(path, float).reshape(-1, 2)
        if len(self.path) < 2:
            raise ValueError("the global path needs at least 2 points")
        segments = len(self.path) - 1
        self.index = np.clip(np.asarray(first)[:, None] + np.arange(max(int(width), 1))[None, :], 0, segments - 1)

    def nearest(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Nearest path points (n, 2), unit segment directions (n, 2), and whether inside a segment (n,)."""
        a, b = self.path[self.index], self.path[self.index + 1]
        ab = b - a
        length2 = np.maximum(np.einsum("nkd,nkd->nk", ab, ab), 1e-18)
        t = np.clip(np.einsum("nkd,nkd->nk", p[:, None, :] - a, ab) / length2, 0.0, 1.0)
        c = a + t[..., None] * ab
        best = np.argmin(np.einsum("nkd,nkd->nk", p[:, None, :] - c, p[:, None, :] - c), axis=1)
        rows = np.arange(len(p))
        tb = t[rows, best]
        direction = ab[rows, best] / np.sqrt(length2[rows, best])[:, None]
        return c[rows, best], direction, (tb > 0.0) & (tb < 1.0)

    def evaluate(self, values, jacobians):
        p = values[0].reshape(-1, 3)[:, :2]
        c, direction, interior = self.nearest(p)
        r = (p - c).ravel()
        if not jacobians:
            return r, None
        jac = np.eye(2)[None] - interior[:, None, None] * direction[:, :, None] * direction[:, None, :]
        rows = 2 * np.arange(self.n)
        return r, [scatter((self.size, 3 * self.n), [(rows, 3 * np.arange(self.n), jac)])]


class ClearanceBlock(ResidualBlock):
    """r_i = l(p_i): obstacle distance at each pose (bounded from below by `IntervalPenalty`)."""

    def __init__(self, n: int, field: DistanceField):
        self.n = n
        self.field = field
        self.variables = (POSES,)
        self.size = n

    def evaluate(self, values, jacobians):
        p = values[0].reshape(-1, 3)[:, :2]
        value, gradient = self.field.value_and_gradient(p)
        if not jacobians:
            return value, None
        return value, [scatter((self.size, 3 * self.n), [(np.arange(self.n), 3 * np.arange(self.n), gradient[:, None, :])])]


class ViaPointBlock(ResidualBlock):
    """For via point k assigned to pose `index[k]`: rows p − via (2) and, where `heading[k]` is
    finite, wrap(θ − heading) (1). Row order: all position rows, then the heading rows."""

    def __init__(self, n: int, index, points, heading):
        self.n = n
        self.variables = (POSES,)
        self.index = np.asarray(index, int).reshape(-1)
        self.points = np.asarray(points, float).reshape(-1, 2)
        heading = np.asarray(heading, float).reshape(-1)
        self.with_heading = np.flatnonzero(np.isfinite(heading))
        self.heading = heading[self.with_heading]
        self.size = 2 * len(self.index) + len(self.with_heading)

    def evaluate(self, values, jacobians):
        poses = values[0].reshape(-1, 3)
        k = len(self.index)
        hi = self.index[self.with_heading]
        r = np.concatenate([(poses[self.index, :2] - self.points).ravel(), wrap_angle(poses[hi, 2] - self.heading)])
        if not jacobians:
            return r, None
        pieces = [(2 * np.arange(k), 3 * self.index, np.broadcast_to(np.eye(2), (k, 2, 2))),
                  (2 * k + np.arange(len(hi)), 3 * hi + 2, np.ones((len(hi), 1, 1)))]
        return r, [scatter((self.size, 3 * self.n), pieces)]


class YawChangeBlock(ResidualBlock):
    """r_i = wrap(θ_{i+1} − θ_i): the yaw-change penalty of Sec. IV (saves turning effort)."""

    def __init__(self, n: int):
        self.n = n
        self.variables = (POSES,)
        self.size = n - 1

    def evaluate(self, values, jacobians):
        theta = values[0].reshape(-1, 3)[:, 2]
        r = wrap_angle(np.diff(theta))
        if not jacobians:
            return r, None
        rows = np.arange(self.size)
        piece = np.broadcast_to(np.array([[-1.0, 0.0, 0.0, 1.0]]), (self.size, 1, 4))
        return r, [scatter((self.size, 3 * self.n), [(rows, 3 * rows + 2, piece)])]


class NonholonomicBlock(ResidualBlock):
    """Differential-drive kinematics of [19]: the chord Δp_i is parallel to the mean heading,
    r_i = (cos θ_i + cos θ_{i+1}) Δy_i − (sin θ_i + sin θ_{i+1}) Δx_i (zero lateral velocity)."""

    def __init__(self, n: int):
        self.n = n
        self.variables = (POSES,)
        self.size = n - 1

    def evaluate(self, values, jacobians):
        poses = values[0].reshape(-1, 3)
        delta = poses[1:, :2] - poses[:-1, :2]
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        cs, ss = c[:-1] + c[1:], s[:-1] + s[1:]
        r = cs * delta[:, 1] - ss * delta[:, 0]
        if not jacobians:
            return r, None
        d_theta0 = -s[:-1] * delta[:, 1] - c[:-1] * delta[:, 0]
        d_theta1 = -s[1:] * delta[:, 1] - c[1:] * delta[:, 0]
        piece = np.stack([ss, -cs, d_theta0, -ss, cs, d_theta1], axis=1)[:, None, :]
        rows = np.arange(self.size)
        return r, [scatter((self.size, 3 * self.n), [(rows, 3 * rows, piece)])]
