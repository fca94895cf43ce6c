"""Batched rotation-vector maps between unit quaternions, rotation matrices and R^3.

The quaternion conversions are scipy's `Rotation` (batched; inputs are copied, since its Cython
code refuses read-only buffers such as the state views OMPL hands to callbacks); exp (Rodrigues),
the cross-product matrix and the right Jacobian of exp are written out here. Together they
implement the vector parametrization of the base orientation used by the Bézier planner (paper
eq. (1b), SE(3) ≡ R^6): the orientation is the rotation vector ω = θ·axis with θ in [0, π]. All
functions take stacks (n, ...); they agree with pinocchio's `exp3`, `log3` and `Jexp3`
(tests/robots/test_robot_vector.py).
Quaternions are in pinocchio's configuration order (x, y, z, w).
"""

from __future__ import annotations

import numpy as np


_ANGLE_SERIES = 1e-4  # below this rotation angle (rad) exp(ω) uses its Taylor series

_SKEW = np.zeros((3, 9))  # w @ _SKEW = [w]x flattened row-major
_SKEW[2, 1], _SKEW[1, 2], _SKEW[2, 3], _SKEW[0, 5], _SKEW[1, 6], _SKEW[0, 7] = -1, 1, 1, -1, -1, 1


def skew(w: np.ndarray) -> np.ndarray:
    """(..., 3) -> (..., 3, 3) cross-product matrices [w]x (one product with a constant matrix: the
    step planner forms them for every sample and joint)."""
    w = np.asarray(w, float)
    return (w @ _SKEW).reshape(w.shape[:-1] + (3, 3))


def quat_to_rotvec(quat: np.ndarray) -> np.ndarray:
    """Unit quaternions (n, 4) (x, y, z, w) -> rotation vectors (n, 3) with angle in [0, π]."""
    from scipy.spatial.transform import Rotation  # scipy.spatial on first use (start-up time)

    return Rotation.from_quat(np.array(quat, float)).as_rotvec()


def rotvec_to_quat(omega: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) -> unit quaternions (n, 4) (x, y, z, w)."""
    from scipy.spatial.transform import Rotation  # scipy.spatial on first use (start-up time)

    return Rotation.from_rotvec(np.array(omega, float)).as_quat()


def rotvec_to_matrix(omega: np.ndarray) -> np.ndarray:
    """Rotation vectors (n, 3) -> rotation matrices (n, 3, 3) (= pin.exp3), Rodrigues' formula
    exp(ω) = I + (sin θ/θ) [ω]× + ((1 − cos θ)/θ²) [ω]×², θ = ‖ω‖, with the Taylor series of the two
    factors below θ = `_ANGLE_SERIES` (written out: both planners form it for every sample)."""
    omega = np.asarray(omega, float)
    theta2 = np.einsum("...i,...i->...", omega, omega)
    if theta2.min(initial=np.inf) >= _ANGLE_SERIES ** 2:
        theta = np.sqrt(theta2)
        a, b = np.sin(theta) / theta, (1.0 - np.cos(theta)) / theta2
    else:
        small = theta2 < _ANGLE_SERIES ** 2
        t = np.where(small, 1.0, np.sqrt(theta2))
        a = np.where(small, 1.0 - theta2 / 6.0, np.sin(t) / t)
        b = np.where(small, 0.5 - theta2 / 24.0, (1.0 - np.cos(t)) / (t * t))
    K = skew(omega)
    return np.eye(3) + a[..., None, None] * K + b[..., None, None] * (K @ K)


def _coefficients(theta: np.ndarray):
    """b = (1 - cos θ) / θ², c = (θ - sin θ) / θ³ with their small-angle series."""
    small = theta < 1e-4
    t = np.where(small, 1.0, theta)
    t2 = theta**2
    b = np.where(small, 0.5 - t2 / 24.0, (1.0 - np.cos(t)) / t**2)
    c = np.where(small, 1.0 / 6.0 - t2 / 120.0, (t - np.sin(t)) / t**3)
    return b, c


def right_jacobian(omega: np.ndarray) -> np.ndarray:
    """Right Jacobian Jr(ω) (n, 3, 3) of exp: exp(ω + δ) ≈ exp(ω) exp(Jr(ω) δ) (= pin.Jexp3)."""
    omega = np.asarray(omega, float)
    b, c = _coefficients(np.linalg.norm(omega, axis=-1))
    K = skew(omega)
    return np.eye(3) - b[..., None, None] * K + c[..., None, None] * (K @ K)
