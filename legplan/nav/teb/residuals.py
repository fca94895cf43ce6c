"""Residual terms of the TEB objective R(B) = Σ_k γ_k R_k(B) of eq. (24), with fixed-pattern Jacobians.

Every term reads the band vector z = [x_0, y_0, θ_0, x_1, …, θ_{n−1}, ΔT_0, …, ΔT_{n−2}]
(`band_vector`, seen through a `BandState`) and returns its values with the *values* of its Jacobian on a COO pattern
(`rows`, `cols`) that depends only on the band size and the term's structure (`Term.key`) and is
computed once per key (`cached_pattern`); an iteration refreshes only numpy value arrays (no
scipy.sparse objects). Terms that express limits return the limited
quantity itself; `TebObjective` (objective.py) turns it into the TEB interval penalty.

* `VelocityTerm`      — (v_x, v_y, ω) per interval, eqs. (21)–(23)
* `AccelerationTerm`  — (a_x, a_y, α) between intervals, eq. (23), plus start/goal velocity rows
* `TimeTerm`          — ΔT_i (time optimality)
* `PathTerm`          — p_i − nearest point of the global path (attraction)
* `ClearanceTerm`     — l(p_i), distance to the nearest obstacle (repulsion via a lower bound)
* `ViaPointTerm`      — p_k − via point (and θ_k − heading) for the pose assigned to each via point
* `YawChangeTerm`     — Δθ_i, the paper's yaw-change penalty (Sec. IV)
* `NonholonomicTerm`  — (cos θ_i + cos θ_{i+1}) Δy_i − (sin θ_i + sin θ_{i+1}) Δx_i, the
  differential-drive kinematics residual of [19] (lateral velocity forced to zero)

Each term is also a `legplan.solve.ResidualBlock` over the variable `band` (its `evaluate` builds
the sparse Jacobian from the pattern), so `check_jacobian` tests it directly.
"""

from __future__ import annotations

from abc import abstractmethod
from functools import cached_property

import numpy as np
import scipy.sparse as sp

from legplan.geometry.angles import wrap_angle
from legplan.nav.teb.band import Band, interval_accelerations, interval_velocities
from legplan.nav.teb.distance import DistanceField
from legplan.solve import ResidualBlock

BAND = "band"


def band_vector(band: Band) -> np.ndarray:
    """z = [poses (3n, row-major), dt (n − 1)]."""
    return np.concatenate([band.poses.ravel(), band.dt])


def split_vector(z: np.ndarray, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Poses (n, 3) and intervals (n − 1,) of a band vector."""
    return z[:3 * n].reshape(n, 3), z[3 * n:]


def pattern(pieces) -> tuple[np.ndarray, np.ndarray]:
    """COO rows and cols of dense pieces (row0 (m,), col0 (m,), (r, c)), each piece an (m, r, c)
    block per entry, in the order `np.ravel` flattens an (m, r, c) value array."""
    rows, cols = [], []
    for row0, col0, (r, c) in pieces:
        row0, col0 = np.asarray(row0, np.int64), np.asarray(col0, np.int64)
        shape = (row0.size, r, c)
        rows.append(np.broadcast_to(row0[:, None, None] + np.arange(r)[None, :, None], shape).ravel())
        cols.append(np.broadcast_to(col0[:, None, None] + np.arange(c)[None, None, :], shape).ravel())
    return np.concatenate(rows), np.concatenate(cols)


_PATTERNS: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
MAX_PATTERNS = 512  # cached patterns before the cache is cleared


def cached_pattern(key: tuple, pieces) -> tuple[np.ndarray, np.ndarray]:
    """`pattern(pieces())`, computed once per `key`; the arrays are shared and read-only."""
    found = _PATTERNS.get(key)
    if found is None:
        if len(_PATTERNS) >= MAX_PATTERNS:
            _PATTERNS.clear()
        parts = pieces()
        found = pattern(parts) if parts else (np.zeros(0, np.int64), np.zeros(0, np.int64))
        for a in found:
            a.setflags(write=False)
        _PATTERNS[key] = found
    return found


def flat(*values) -> np.ndarray:
    """Concatenated ravelled value pieces (same order as the `pattern` pieces)."""
    return np.concatenate([np.asarray(v, float).ravel() for v in values])


class BandState:
    """One evaluation point of the band: poses (n, 3), intervals dt (n − 1,), whether Jacobians are
    wanted, and the interval velocities of eqs. (21)–(23) computed once for all terms that use them."""

    def __init__(self, z: np.ndarray, n: int, jacobian: bool):
        self.poses, self.dt = split_vector(np.asarray(z, float), n)
        self.jacobian = jacobian

    @cached_property
    def velocities(self):
        return interval_velocities(self.poses, self.dt, self.jacobian)


class Term(ResidualBlock):
    """A TEB term over z: `linearize(state)` -> (values (size,), Jacobian values on (`rows`, `cols`)
    when `state.jacobian`, else None). `key` identifies the pattern: terms with equal keys have
    equal `rows` and `cols`; `pieces()` gives the `pattern` pieces when the key is new."""

    variables = (BAND,)

    def __init__(self, n: int, size: int, structure: tuple, pieces):
        self.n = n
        self.size = int(size)
        self.columns = 4 * n - 1
        self.key = (type(self).__name__, n, *structure)
        self.rows, self.cols = cached_pattern(self.key, pieces)

    @abstractmethod
    def linearize(self, state: BandState) -> tuple[np.ndarray, np.ndarray | None]:
        """Values and (if `state.jacobian`) Jacobian values on the fixed pattern."""

    def evaluate(self, values, jacobians):
        x, vals = self.linearize(BandState(values[0], self.n, jacobians))
        if not jacobians:
            return x, None
        return x, [sp.coo_matrix((vals, (self.rows, self.cols)), shape=(self.size, self.columns))]


class VelocityTerm(Term):
    """Body-frame (v_x, v_y, ω) of every interval (rows 3i … 3i + 2), eq. (23)."""

    def __init__(self, n: int):
        m = n - 1
        r, i = 3 * np.arange(m), np.arange(m)
        super().__init__(n, 3 * m, (), lambda: [(r, 3 * i, (3, 3)), (r, 3 * i + 3, (3, 3)), (r, 3 * n + i, (3, 1))])

    def linearize(self, state):
        v, jv = state.velocities
        return v.ravel(), (flat(jv.d_start, jv.d_end, jv.d_dt) if state.jacobian else None)


class AccelerationTerm(Term):
    """(a_x, a_y, α) of eq. (23) for consecutive intervals, then optionally 3 rows for the start,
    (v_0 − v_start)/ΔT_0, and 3 for the goal, (v_goal − v_{n−2})/ΔT_{n−2} (body-frame velocities)."""

    def __init__(self, n: int, start_velocity=None, goal_velocity=None):
        self.start_velocity = None if start_velocity is None else np.asarray(start_velocity, float).reshape(3)
        self.goal_velocity = None if goal_velocity is None else np.asarray(goal_velocity, float).reshape(3)
        m = max(n - 2, 0)
        r, i = 3 * np.arange(m), np.arange(m)
        pieces = [(r, 3 * i, (3, 3)), (r, 3 * i + 3, (3, 3)), (r, 3 * i + 6, (3, 3)),
                  (r, 3 * n + i, (3, 1)), (r, 3 * n + i + 1, (3, 1))] if m else []
        self.inner = 3 * m
        row = self.inner
        self.boundaries = []
        for boundary, k, sign in ((self.start_velocity, 0, 1.0), (self.goal_velocity, n - 2, -1.0)):
            if boundary is not None:
                self.boundaries.append((boundary, k, sign))
                pieces += [([row], [3 * k], (3, 3)), ([row], [3 * k + 3], (3, 3)), ([row], [3 * n + k], (3, 1))]
                row += 3
        super().__init__(n, row, (self.start_velocity is not None, self.goal_velocity is not None), lambda: pieces)

    def linearize(self, state):
        poses, dt, jacobian = state.poses, state.dt, state.jacobian
        parts, vals = [], []
        v, jv = velocities = state.velocities
        if self.inner:
            a, ja = interval_accelerations(poses, dt, velocities, jacobian)
            parts.append(a.ravel())
            if jacobian:
                vals += [ja.d_pose0, ja.d_pose1, ja.d_pose2, ja.d_dt0, ja.d_dt1]
        for boundary, k, sign in self.boundaries:
            inv = 1.0 / dt[k]
            acc = sign * (v[k] - boundary) * inv
            parts.append(acc)
            if jacobian:
                vals += [sign * inv * jv.d_start[k], sign * inv * jv.d_end[k], sign * inv * jv.d_dt[k] - acc * inv]
        x = np.concatenate(parts) if parts else np.zeros(0)
        return x, ((flat(*vals) if vals else np.zeros(0)) if jacobian else None)


class TimeTerm(Term):
    """r_i = ΔT_i: the time-optimality term (its square sums to Σ ΔT_i²)."""

    def __init__(self, n: int):
        super().__init__(n, n - 1, (), lambda: [(np.arange(n - 1), 3 * n + np.arange(n - 1), (1, 1))])
        self._ones = np.ones(n - 1)

    def linearize(self, state):
        return state.dt.copy(), (self._ones if state.jacobian else None)


class PathTerm(Term):
    """r_i = p_i − c_i with c_i the nearest point of the global path polyline (attraction).

    Pose i searches only the `width` segments starting at `first[i]` (a window of the path around
    the pose's own part of it), so a path that folds back does not capture the wrong stretch.
    The Jacobian is I − t tᵀ when c_i lies inside a segment of unit direction t, I at a vertex.
    """

    def __init__(self, n: int, path: np.ndarray, first: np.ndarray, width: int):
        self.path = np.asarray(path, float).reshape(-1, 2)
        if len(self.path) < 2:
            raise ValueError("the global path needs at least 2 points")
        segments = len(self.path) - 1
        self.index = np.clip(np.asarray(first)[:, None] + np.arange(max(int(width), 1))[None, :], 0, segments - 1)
        i = np.arange(n)
        super().__init__(n, 2 * n, (), lambda: [(2 * i, 3 * i, (2, 2))])
        a = self.path[self.index]
        ab = self.path[self.index + 1] - a
        length = np.maximum(np.hypot(ab[..., 0], ab[..., 1]), 1e-9)
        self._ax, self._ay, self._abx, self._aby = a[..., 0], a[..., 1], ab[..., 0], ab[..., 1]
        self._inv_length2 = 1.0 / (length * length)
        self._ux, self._uy = (ab[..., 0] / length).ravel(), (ab[..., 1] / length).ravel()
        self._row_start = np.arange(n) * self.index.shape[1]

    def nearest(self, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """p − (nearest path point) (n, 2), unit direction of its segment (n, 2), and whether it lies
        inside the segment (n,)."""
        dx, dy = p[:, :1] - self._ax, p[:, 1:2] - self._ay
        t = (dx * self._abx + dy * self._aby) * self._inv_length2
        np.clip(t, 0.0, 1.0, out=t)
        ex, ey = dx - t * self._abx, dy - t * self._aby
        flat = self._row_start + np.argmin(ex * ex + ey * ey, axis=1)
        tb = t.ravel()[flat]
        offset = np.column_stack([ex.ravel()[flat], ey.ravel()[flat]])
        return offset, np.column_stack([self._ux[flat], self._uy[flat]]), (tb > 0.0) & (tb < 1.0)

    def linearize(self, state):
        offset, direction, interior = self.nearest(state.poses[:, :2])
        r = offset.ravel()
        if not state.jacobian:
            return r, None
        return r, (np.eye(2)[None] - interior[:, None, None] * direction[:, :, None] * direction[:, None, :]).ravel()


class ClearanceTerm(Term):
    """r_i = l(p_i): obstacle distance at each pose (bounded from below by the objective's penalty)."""

    def __init__(self, n: int, field: DistanceField):
        self.field = field
        i = np.arange(n)
        super().__init__(n, n, (), lambda: [(i, 3 * i, (1, 2))])

    def linearize(self, state):
        value, gradient = self.field.value_and_gradient(state.poses[:, :2], state.jacobian)
        return value, (gradient.ravel() if state.jacobian else None)


class ViaPointTerm(Term):
    """For via point k assigned to pose `index[k]`: rows p − via (2) and, where `heading[k]` is
    finite, wrap(θ − heading) (1). Row order: all position rows, then the heading rows."""

    def __init__(self, n: int, index, points, heading):
        self.index = np.asarray(index, int).reshape(-1)
        self.points = np.asarray(points, float).reshape(-1, 2)
        heading = np.asarray(heading, float).reshape(-1)
        self.with_heading = np.flatnonzero(np.isfinite(heading))
        self.heading = heading[self.with_heading]
        k, hi = len(self.index), self.index[self.with_heading]
        self._hi = hi
        super().__init__(n, 2 * k + len(hi), (self.index.tobytes(), hi.tobytes()),
                         lambda: [(2 * np.arange(k), 3 * self.index, (2, 2)), (2 * k + np.arange(len(hi)), 3 * hi + 2, (1, 1))])
        self._values = flat(np.broadcast_to(np.eye(2), (k, 2, 2)), np.ones(len(hi)))

    def linearize(self, state):
        poses = state.poses
        r = np.concatenate([(poses[self.index, :2] - self.points).ravel(), wrap_angle(poses[self._hi, 2] - self.heading)])
        return r, (self._values if state.jacobian else None)


class YawChangeTerm(Term):
    """r_i = wrap(θ_{i+1} − θ_i): the yaw-change penalty of Sec. IV (saves turning effort)."""

    def __init__(self, n: int):
        i = np.arange(n - 1)
        super().__init__(n, n - 1, (), lambda: [(i, 3 * i + 2, (1, 4))])
        self._values = np.tile([-1.0, 0.0, 0.0, 1.0], n - 1)

    def linearize(self, state):
        return wrap_angle(np.diff(state.poses[:, 2])), (self._values if state.jacobian else None)


class NonholonomicTerm(Term):
    """Differential-drive kinematics of [19]: the chord Δp_i is parallel to the mean heading,
    r_i = (cos θ_i + cos θ_{i+1}) Δy_i − (sin θ_i + sin θ_{i+1}) Δx_i (zero lateral velocity)."""

    def __init__(self, n: int):
        i = np.arange(n - 1)
        super().__init__(n, n - 1, (), lambda: [(i, 3 * i, (1, 6))])

    def linearize(self, state):
        poses = state.poses
        delta = poses[1:, :2] - poses[:-1, :2]
        c, s = np.cos(poses[:, 2]), np.sin(poses[:, 2])
        cs, ss = c[:-1] + c[1:], s[:-1] + s[1:]
        r = cs * delta[:, 1] - ss * delta[:, 0]
        if not state.jacobian:
            return r, None
        d_theta0 = -s[:-1] * delta[:, 1] - c[:-1] * delta[:, 0]
        d_theta1 = -s[1:] * delta[:, 1] - c[1:] * delta[:, 0]
        return r, np.stack([ss, -cs, d_theta0, -ss, cs, d_theta1], axis=1).ravel()
