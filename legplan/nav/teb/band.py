"""The timed elastic band B = (Q, τ) of eq. (20) and the body-frame kinematics of eqs. (21)–(23).

Q holds n poses s_i = [x_i, y_i, θ_i] (world frame), τ the n − 1 time intervals ΔT_i. `fixed[i]`
marks poses the optimizer must not move and resizing must not remove (at least start and goal).

`interval_velocities` and `interval_accelerations` evaluate eqs. (22)–(23) for every interval and
also return the per-interval Jacobian pieces that the residual blocks scatter into sparse
matrices. Yaw differences are wrapped to (−π, π] (`wrap_angle`), so the band turns the short way.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from legplan.geometry.angles import wrap_angle


@dataclass
class Band:
    """Poses (n, 3) [x, y, θ], intervals dt (n − 1,), fixed-pose mask (n,) (default: start and goal)."""

    poses: np.ndarray
    dt: np.ndarray
    fixed: np.ndarray = field(default=None)

    def __post_init__(self):
        self.poses = np.array(self.poses, float).reshape(-1, 3)
        self.dt = np.array(self.dt, float).reshape(-1)
        n = len(self.poses)
        if n < 2 or self.dt.size != n - 1:
            raise ValueError(f"a band needs n ≥ 2 poses and n − 1 intervals, got {n} poses, {self.dt.size} intervals")
        if np.any(self.dt <= 0):
            raise ValueError("band time intervals must be > 0")
        if self.fixed is None:
            self.fixed = np.zeros(n, bool)
            self.fixed[[0, -1]] = True
        self.fixed = np.array(self.fixed, bool).reshape(n)

    @property
    def n(self) -> int:
        return len(self.poses)

    @property
    def times(self) -> np.ndarray:
        """Time of every pose from the band start, (n,)."""
        return np.concatenate([[0.0], np.cumsum(self.dt)])

    @property
    def duration(self) -> float:
        return float(self.dt.sum())

    def copy(self) -> Band:
        return Band(self.poses.copy(), self.dt.copy(), self.fixed.copy())

    def velocities(self) -> np.ndarray:
        """Body-frame (v_x, v_y, ω) of every interval, (n − 1, 3), eq. (23)."""
        return interval_velocities(self.poses, self.dt, jacobian=False)[0]

    def accelerations(self) -> np.ndarray:
        """Body-frame (a_x, a_y, α) between consecutive intervals, (n − 2, 3), eq. (23)."""
        if self.n < 3:
            return np.zeros((0, 3))
        return interval_accelerations(self.poses, self.dt, jacobian=False)[0]

    def effort(self) -> float:
        """Translational effort Σ (a_x² + a_y²)·(ΔT_i + ΔT_{i+1})/2, the band's discrete eq. (4)."""
        a = self.accelerations()
        return float(np.sum((a[:, 0] ** 2 + a[:, 1] ** 2) * 0.5 * (self.dt[:-1] + self.dt[1:])))


@dataclass(frozen=True)
class VelocityJacobian:
    """Per-interval pieces of ∂v_i/∂(s_i, s_{i+1}, ΔT_i): (m, 3, 3), (m, 3, 3), (m, 3)."""

    d_start: np.ndarray
    d_end: np.ndarray
    d_dt: np.ndarray


def interval_velocities(poses: np.ndarray, dt: np.ndarray, jacobian: bool = True) -> tuple[np.ndarray, VelocityJacobian | None]:
    """v_i = (dx_i, dy_i, Δθ_i)/ΔT_i of eqs. (21)–(23), rotated by θ_i (eq. (22)), and (if
    `jacobian`) its Jacobian."""
    poses = np.asarray(poses, float).reshape(-1, 3)
    delta = poses[1:] - poses[:-1]
    c, s = np.cos(poses[:-1, 2]), np.sin(poses[:-1, 2])
    dx = c * delta[:, 0] + s * delta[:, 1]
    dy = -s * delta[:, 0] + c * delta[:, 1]
    inv = 1.0 / dt
    v = np.empty((len(dt), 3))
    v[:, 0], v[:, 1], v[:, 2] = dx * inv, dy * inv, wrap_angle(delta[:, 2]) * inv
    if not jacobian:
        return v, None
    d_end = np.zeros((len(dt), 3, 3))
    d_end[:, 0, 0], d_end[:, 0, 1], d_end[:, 1, 0], d_end[:, 1, 1], d_end[:, 2, 2] = c * inv, s * inv, -s * inv, c * inv, inv
    d_start = -d_end
    d_start[:, 0, 2] = dy * inv
    d_start[:, 1, 2] = -dx * inv
    return v, VelocityJacobian(d_start, d_end, -v * inv[:, None])


@dataclass(frozen=True)
class AccelerationJacobian:
    """Pieces of ∂a_i/∂(s_i, s_{i+1}, s_{i+2}) (m, 3, 3) each and ∂a_i/∂(ΔT_i, ΔT_{i+1}) (m, 3) each."""

    d_pose0: np.ndarray
    d_pose1: np.ndarray
    d_pose2: np.ndarray
    d_dt0: np.ndarray
    d_dt1: np.ndarray


def interval_accelerations(poses: np.ndarray, dt: np.ndarray, velocities=None,
                           jacobian: bool = True) -> tuple[np.ndarray, AccelerationJacobian | None]:
    """a_i = (v_{i+1} − v_i) / ((ΔT_i + ΔT_{i+1})/2) of eq. (23) for i = 0 … n − 3, and (if
    `jacobian`) its Jacobian; `velocities` = `interval_velocities(poses, dt, jacobian)` if already known."""
    v, jv = interval_velocities(poses, dt, jacobian) if velocities is None else velocities
    total = dt[:-1] + dt[1:]
    k = (2.0 / total)[:, None]
    a = (v[1:] - v[:-1]) * k
    if not jacobian:
        return a, None
    kk = k[:, :, None]
    d_total = -a / total[:, None]
    jac = AccelerationJacobian(d_pose0=-kk * jv.d_start[:-1], d_pose1=kk * (jv.d_start[1:] - jv.d_end[:-1]),
                               d_pose2=kk * jv.d_end[1:], d_dt0=-k * jv.d_dt[:-1] + d_total,
                               d_dt1=k * jv.d_dt[1:] + d_total)
    return a, jac
