"""Batched rotation-vector maps between unit quaternions, rotation matrices and R^3.

They implement the vector parametrization of the base orientation used by the Bézier planner
(paper eq. (1b), SE(3) ≡ R^6): the orientation is the rotation vector ω = θ·axis with θ in [0, π].
All functions take stacks (n, ...) and have no Python loop; they agree with pinocchio's
`exp3`, `log3` and `Jexp3` (tests/robots/test_robot_vector.py).
Quaternions are in pinocchio's configuration order (x, y, z, w).
"""

from __future__ import annotations

import numpy as np

_SMALL = 1e-6


def skew(w: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices [w]x."""
    w = np.asarray(w, float)
    out = np.zeros(w.shape[:-1] + (3, 3))
    out[..., 0, 1], out[..., 0, 2] = -w[..., 2], w[..., 1]
    out[..., 1, 0], out[..., 1, 2] = w[..., 2], -w[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -w[..., 1], w[..., 0]
    return out


def quat_to_rotvec(quat: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) (x, y, z, w) -> rotation vectors (n, 3) with angle in [0, π]."""
    quat = np.asarray(quat, float)
    quat = quat / np.linalg.norm(quat, axis=-1, keepdims=True)
    quat = np.where(quat[..., 3:4] < 0.0, -quat, quat)
    xyz, w = quat[..., :3], quat[..., 3]
    s = np.linalg.norm(xyz, axis=-1)
    small = s < _SMALL
    # 2 atan2(s, w) / s, whose limit for s -> 0 is 2 / w (w -> 1); series keeps it smooth.
    factor = np.where(small, 2.0 / w * (1.0 - s**2 / (3.0 * w**2)),
                      2.0 * np.arctan2(s, w) / np.where(small, 1.0, s))
    return xyz * factor[..., None]


def rotvec_to_quat(omega: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) -> unit quaternions (n, 4) (x, y, z, w)."""
    omega = np.asarray(omega, float)
    theta = np.linalg.norm(omega, axis=-1)
    small = theta < _SMALL
    safe = np.where(small, 1.0, theta)
    half_sinc = np.where(small, 0.5 - theta**2 / 48.0, np.sin(0.5 * theta) / safe)
    return np.concatenate([omega * half_sinc[..., None], np.cos(0.5 * theta)[..., None]], axis=-1)


def _coefficients(theta: np.ndarray):
    """a = sin θ / θ, b = (1 - cos θ) / θ², c = (θ - sin θ) / θ³ with their small-angle series."""
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    t2 = theta**2
    a = np.where(small, 1.0 - t2 / 6.0, np.sin(t) / t)
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(t)) / t**2)
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0, (t - np.sin(t)) / t**3)
    return a, b, c


def rotvec_to_matrix(omega: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) -> rotation matrices (n, 3, 3) (Rodrigues, = pin.exp3)."""
    omega = np.asarray(omega, float)
    a, b, _ = _coefficients(np.linalg.norm(omega, axis=-1))
    K = skew(omega)
    return np.eye(3) + a[..., None, None] * K + b[..., None, None] * (K @ K)


def right_jacobian(omega: np.ndarray) -> np.ndarray:
    """Right Jacobian Jr(ω) (n, 3, 3) of exp: exp(ω + δ) ≈ exp(ω) exp(Jr(ω) δ) (= pin.Jexp3)."""
    omega = np.asarray(omega, float)
    _, b, c = _coefficients(np.linalg.norm(omega, axis=-1))
    K = skew(omega)
    return np.eye(3) - b[..., None, None] * K + c[..., None, None] * (K @ K)
