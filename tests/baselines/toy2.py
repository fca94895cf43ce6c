"""An analytic two-legged robot for the constrained-planning tests (no URDF, no pinocchio).

x = q = [p (3), ω (3), 3 joints per leg] (nx = 12, `tangent_map` = I); foot l is at
hip_l + p + ω × hip_l + j_l + WAVE·sin(j_l), a small-rotation body with prismatic-like legs bent by a
sine so the constraint is nonlinear. `kinematics(Q)` returns what `StanceConstraint` reads.
"""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

HIPS = np.array([[0.0, 0.15, 0.0], [0.0, -0.15, 0.0]])
WAVE = 0.05


def _skew(v):
    x, y, z = v
    return np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])


class TwoLegToy:
    nv = nx = 12
    n_joints = 6

    def __init__(self):
        self.lower = np.full(6, -0.5)
        self.upper = np.full(6, 0.5)

    def from_vector(self, X):
        return np.atleast_2d(np.asarray(X, float))

    def tangent_map(self, X):
        return np.broadcast_to(np.eye(12), (len(np.atleast_2d(X)), 12, 12)).copy()

    def foot_positions(self, Q):
        Q = np.atleast_2d(Q)
        p, w, j = Q[:, :3], Q[:, 3:6], Q[:, 6:].reshape(-1, 2, 3)
        return p[:, None] + HIPS + np.cross(w[:, None], HIPS) + j + WAVE * np.sin(j)

    def foot_jacobians(self, Q):
        Q = np.atleast_2d(Q)
        J = np.zeros((len(Q), 2, 3, 12))
        j = Q[:, 6:].reshape(-1, 2, 3)
        for leg in range(2):
            J[:, leg, :, :3] = np.eye(3)
            J[:, leg, :, 3:6] = -_skew(HIPS[leg])
            for a in range(3):
                J[:, leg, a, 6 + 3 * leg + a] = 1 + WAVE * np.cos(j[:, leg, a])
        return J

    def kinematics(self, Q, jacobians=True):
        return SimpleNamespace(foot_positions=self.foot_positions(Q),
                               foot_jacobians=self.foot_jacobians(Q) if jacobians else None)

    def configuration(self, base, feet) -> np.ndarray:
        """x with base position `base`, no rotation, feet at `feet` (2, 3) (Newton per joint)."""
        x = np.zeros(12)
        x[:3] = base
        target = (np.asarray(feet, float) - np.asarray(base, float) - HIPS).reshape(-1)
        j = target.copy()
        for _ in range(50):
            j -= (j + WAVE * np.sin(j) - target) / (1 + WAVE * np.cos(j))
        x[6:] = j
        return x
