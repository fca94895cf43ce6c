"""A small analytic four-legged test robot and terrain for the step planner's unit tests.

It implements the batch interface the planner reads from the robot layer (vector parametrization
x = q = [p, ω, 3 joints per leg], `tangent_map` = I) with simple nonlinear kinematics, so the
Bézier block can be checked against finite differences without a URDF. Feet: hip_l + p + ω × hip_l
+ j_l + a·sin(j_l); one sphere per foot plus one body sphere. Terrain: z = bump(x, y), a Gaussian
hill, with `value_and_gradient` of z − bump (a smooth stand-in for an SDF).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

HIPS = np.array([[0.2, 0.15, 0.0], [0.2, -0.15, 0.0], [-0.2, 0.15, 0.0], [-0.2, -0.15, 0.0]])
WAVE = 0.05


def _skew(v):
    x, y, z = v
    return np.array([[0, -z, y], [z, 0, -x], [-y, x, 0]])


@dataclass(frozen=True)
class ToyLeg:
    name: str


@dataclass(frozen=True)
class ToySpheres:
    frame_ids: np.ndarray
    offsets: np.ndarray
    radii: np.ndarray
    leg_index: np.ndarray
    is_foot: np.ndarray


class ToyRobot:
    name = "toy"
    nq = nv = 18
    n_joints = 12

    def __init__(self):
        self.legs = tuple(ToyLeg(n) for n in ("lf", "rf", "lh", "rh"))
        self.lower = np.full(12, -0.3)
        self.upper = np.full(12, 0.3)
        self.lower[2::3] = -0.35  # vertical joints reach down to the ground at z = 0
        self.q_nominal = np.zeros(18)
        self.q_nominal[2] = 0.3
        self.q_nominal[6:] = np.tile([0.0, 0.0, -0.3 - WAVE * np.sin(-0.3)], 4)
        self.spheres = ToySpheres(np.zeros(5, int), np.zeros((5, 3)), np.array([0.0, 0, 0, 0, 0.1]),
                                  np.array([0, 1, 2, 3, -1]), np.array([True, True, True, True, False]))

    def kinematics(self, Q, jacobians=True):
        """Nothing to cache: every call below is analytic."""

    def to_vector(self, Q):
        return np.array(Q, float)

    def from_vector(self, X):
        return np.array(X, float)

    def tangent_map(self, X):
        return np.broadcast_to(np.eye(18), (len(X), 18, 18)).copy()

    def foot_positions(self, Q):
        Q = np.atleast_2d(Q)
        p, w, j = Q[:, :3], Q[:, 3:6], Q[:, 6:].reshape(-1, 4, 3)
        return p[:, None] + HIPS + np.cross(w[:, None], HIPS) + j + WAVE * np.sin(j)

    def foot_jacobians(self, Q):
        Q = np.atleast_2d(Q)
        J = np.zeros((len(Q), 4, 3, 18))
        j = Q[:, 6:].reshape(-1, 4, 3)
        for leg in range(4):
            J[:, leg, :, :3] = np.eye(3)
            J[:, leg, :, 3:6] = -_skew(HIPS[leg])
            for a in range(3):
                J[:, leg, a, 6 + 3 * leg + a] = 1 + WAVE * np.cos(j[:, leg, a])
        return J

    def sphere_centres(self, Q):
        Q = np.atleast_2d(Q)
        return np.concatenate([self.foot_positions(Q), Q[:, None, :3]], axis=1)

    def sphere_jacobians(self, Q):
        Q = np.atleast_2d(Q)
        body = np.zeros((len(Q), 1, 3, 18))
        body[:, 0, :, :3] = np.eye(3)
        return np.concatenate([self.foot_jacobians(Q), body], axis=1)

    def com(self, Q):
        Q = np.atleast_2d(Q)
        return Q[:, :3] + 0.1 * self.foot_positions(Q).mean(axis=1) - 0.1 * Q[:, :3]

    def com_jacobian(self, Q):
        Q = np.atleast_2d(Q)
        J = 0.1 * self.foot_jacobians(Q).mean(axis=1)
        J[:, :, :3] += 0.9 * np.eye(3) - 0.1 * np.eye(3) + 0.1 * np.eye(3)
        return J


class ToyHill:
    """Terrain z = h·exp(−|xy − c|²/(2s²)); `value_and_gradient` of z − bump(xy)."""

    def __init__(self, centre=(0.3, 0.15), height=0.0, width=0.04):
        self.centre = np.asarray(centre, float)
        self.h, self.s = float(height), float(width)

    def bump(self, xy):
        d = xy - self.centre
        return self.h * np.exp(-(d ** 2).sum(-1) / (2 * self.s ** 2))

    def value_and_gradient(self, points, bound=None):
        points = np.asarray(points, float)
        b = self.bump(points[:, :2])
        grad = np.zeros_like(points)
        grad[:, :2] = b[:, None] * (points[:, :2] - self.centre) / self.s ** 2
        grad[:, 2] = 1.0
        return points[:, 2] - b, grad

    def values(self, points, bound=None):
        return self.value_and_gradient(points)[0]


def toy_configuration(base, feet) -> np.ndarray:
    """Toy configuration with base position `base`, no rotation, feet at `feet` (4, 3) (Newton on the joints)."""
    q = np.zeros(18)
    q[:3] = base
    target = (np.asarray(feet, float) - np.asarray(base, float) - HIPS).reshape(-1)
    j = target.copy()
    for _ in range(50):
        j -= (j + WAVE * np.sin(j) - target) / (1 + WAVE * np.cos(j))
    q[6:] = j
    return q
