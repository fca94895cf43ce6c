"""Batch forward kinematics and point Jacobians over many configurations (one pin.Data reused).

Every quantity the planners need is a point rigidly attached to a joint: foot tips, collision
sphere centres and the centres of mass of the bodies (whose mass-weighted mean is the CoM).
Per configuration one `pin.computeJointJacobians` (forward kinematics + joint Jacobians in the
WORLD frame) is run and the joint placements are read; everything else is batched numpy:

    p = R_j o + t_j,        J_p = S_j ⊙ (J_lin + J_ang × p)      (LOCAL_WORLD_ALIGNED, w.r.t. v)

where (J_lin; J_ang) are the columns of `data.J` (spatial velocity at the world origin) and S_j
masks the columns of the joints supporting joint j. The CoM Jacobian is Σ m_b J_{c_b} / M.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin


@dataclass(frozen=True)
class AttachedPoints:
    """Points attached to joints: parent joint ids (p,), offsets (p, 3) in the joint frame."""

    joints: np.ndarray
    offsets: np.ndarray

    @staticmethod
    def of_frames(model: pin.Model, frame_ids, offsets=None) -> AttachedPoints:
        """Points `offsets` (k, 3) given in frames `frame_ids` (default: the frame origins)."""
        frame_ids = np.asarray(frame_ids, int)
        offsets = np.zeros((len(frame_ids), 3)) if offsets is None else np.asarray(offsets, float)
        joints = np.array([model.frames[int(f)].parentJoint for f in frame_ids], int)
        placed = np.array([model.frames[int(f)].placement.act(o) for f, o in zip(frame_ids, offsets)])
        return AttachedPoints(joints, placed.reshape(-1, 3))

    @staticmethod
    def of_body_coms(model: pin.Model) -> AttachedPoints:
        """Centres of mass of the bodies of joints 1..njoints-1."""
        joints = list(range(1, model.njoints))
        return AttachedPoints(np.array(joints), np.array([model.inertias[j].lever for j in joints]))


@dataclass(frozen=True)
class Kinematics:
    """Batch results for n configurations: positions (n, k, 3), Jacobians (n, k, 3, nv)."""

    foot_positions: np.ndarray
    foot_jacobians: np.ndarray | None
    sphere_centres: np.ndarray
    sphere_jacobians: np.ndarray | None
    com: np.ndarray
    com_jacobian: np.ndarray | None


class KinematicsWorkspace:
    """The mutable half of a robot: a `pin.Data` and the last batch evaluated (not thread-safe).

    `evaluate(Q, jacobians)` caches its result, so `foot_jacobians`, `sphere_jacobians` and
    `com_jacobian` of the same batch Q cost one pass over the configurations.
    """

    def __init__(self, model: pin.Model, feet: AttachedPoints, spheres: AttachedPoints):
        self.model = model
        self.data = model.createData()
        bodies = AttachedPoints.of_body_coms(model)
        masses = np.array([model.inertias[int(j)].mass for j in bodies.joints])
        total = masses.sum()  # a massless URDF has no CoM (NaN); `robot check` reports it as an error
        self._weights = masses / total if total > 0 else np.full_like(masses, np.nan)
        self._groups = (len(feet.joints), len(spheres.joints), len(bodies.joints))
        self._points = AttachedPoints(np.concatenate([feet.joints, spheres.joints, bodies.joints]),
                                      np.concatenate([feet.offsets, spheres.offsets, bodies.offsets]))
        self._used_joints, self._slot = np.unique(self._points.joints, return_inverse=True)
        support = np.zeros((model.njoints, model.nv), bool)
        for j in range(1, model.njoints):
            for k in model.supports[j]:
                if k > 0:
                    support[j, model.idx_vs[k]:model.idx_vs[k] + model.nvs[k]] = True
        self._mask = support[self._points.joints]                        # (p, nv)
        self._feet = feet
        self._feet_joints, self._feet_slot = np.unique(feet.joints, return_inverse=True)
        self._feet_mask = support[feet.joints]
        self._cache_key: np.ndarray | None = None
        self._cache: Kinematics | None = None

    def evaluate(self, Q: np.ndarray, jacobians: bool) -> Kinematics:
        """Feet, spheres and CoM (and their Jacobians if asked) for configurations Q (n, nq)."""
        cached = self._cache
        if (cached is not None and self._cache_key.shape == Q.shape and np.array_equal(self._cache_key, Q)
                and (cached.com_jacobian is not None or not jacobians)):
            return cached
        result = self._compute(Q, jacobians)
        self._cache_key, self._cache = Q.copy(), result
        return result

    def feet(self, Q: np.ndarray, jacobians: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Foot positions (n, n_legs, 3) and, if asked, their Jacobians (n, n_legs, 3, nv) alone: the
        same numbers as `evaluate`'s feet without the spheres and bodies (leg IK needs only these).
        Not cached, and it leaves `evaluate`'s cache alone."""
        placements, J = self._joint_placements(Q, self._feet_joints, jacobians)
        points = _attached(placements[:, self._feet_slot], self._feet.offsets)
        if not jacobians:
            return points, None
        jac = _point_jacobians(J, points)
        jac *= self._feet_mask[None, :, None, :]
        return points, jac

    def _joint_placements(self, Q: np.ndarray, joint_ids: np.ndarray, jacobians: bool):
        """Placements (n, j, 4, 4) of the joints `joint_ids` and, if asked, the WORLD joint
        Jacobians `data.J` (n, 6, nv) of every configuration of Q."""
        model, data = self.model, self.data
        n, used = len(Q), [int(j) for j in joint_ids]
        placements = np.empty((n, len(used), 4, 4))
        J = np.empty((n, 6, model.nv)) if jacobians else None
        oMi = data.oMi
        for i, q in enumerate(Q):
            if jacobians:
                pin.computeJointJacobians(model, data, q)
                J[i] = data.J
            else:
                pin.forwardKinematics(model, data, q)
            joints = oMi.tolist()  # one conversion of the vector: faster than indexing it per joint
            placements[i] = [joints[j].homogeneous for j in used]
        return placements, J

    def _compute(self, Q: np.ndarray, jacobians: bool) -> Kinematics:
        placements, J = self._joint_placements(Q, self._used_joints, jacobians)
        points = _attached(placements[:, self._slot], self._points.offsets)   # (n, p, 3)
        jac = None
        if jacobians:
            jac = _point_jacobians(J, points)
            jac *= self._mask[None, :, None, :]
        n_feet, n_spheres, _ = self._groups
        feet, spheres = slice(0, n_feet), slice(n_feet, n_feet + n_spheres)
        bodies = slice(n_feet + n_spheres, None)
        com = np.einsum("b,nbi->ni", self._weights, points[:, bodies])
        return Kinematics(
            foot_positions=_read_only(points[:, feet]), sphere_centres=_read_only(points[:, spheres]),
            com=_read_only(com),
            foot_jacobians=None if jac is None else _read_only(jac[:, feet]),
            sphere_jacobians=None if jac is None else _read_only(jac[:, spheres]),
            com_jacobian=None if jac is None else _read_only(
                np.einsum("b,nbij->nij", self._weights, jac[:, bodies])))


def _attached(H: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """World positions (n, p, 3) of points with `offsets` (p, 3) in frames placed at H (n, p, 4, 4):
    R o + t written out per column of R, cheaper than an einsum over the strided 3×3 blocks; the columns
    are summed as (0 + 2) + 1, the order in which numpy's einsum sums them, so the numbers are the same."""
    R = H[..., :3, :3]
    return (R[..., 0] * offsets[:, 0, None] + R[..., 2] * offsets[:, 2, None]) + R[..., 1] * offsets[:, 1, None] \
        + H[..., :3, 3]


def _point_jacobians(J: np.ndarray, points: np.ndarray) -> np.ndarray:
    """J_lin + J_ang × p: WORLD joint Jacobians (n, 6, nv), points (n, p, 3) -> (n, p, 3, nv)."""
    lin, ang = J[:, None, :3, :], J[:, None, 3:, :]
    px, py, pz = (points[:, :, k, None] for k in range(3))
    jac = np.empty(points.shape + (J.shape[-1],))
    jac[:, :, 0] = ang[:, :, 1] * pz - ang[:, :, 2] * py
    jac[:, :, 1] = ang[:, :, 2] * px - ang[:, :, 0] * pz
    jac[:, :, 2] = ang[:, :, 0] * py - ang[:, :, 1] * px
    jac += lin
    return jac


def _read_only(array: np.ndarray) -> np.ndarray:
    """Results are cached and shared between calls: callers must not modify them in place."""
    array.setflags(write=False)
    return array


def one_dof_axis(joint: pin.JointModel, q: np.ndarray) -> tuple[bool, np.ndarray] | None:
    """(revolute?, unit axis in the joint's frame) of a one-degree-of-freedom joint whose motion is
    exp(S q) for a pure rotation or a pure translation S, read from pinocchio's joint model (checked at
    one joint value of the configuration `q`); None for any other joint (several dofs, helical, ...)."""
    if joint.nq != 1 or joint.nv != 1:
        return None
    data = joint.createData()
    probe = q.copy()
    probe[joint.idx_q] = 0.7
    joint.calc(data, probe)
    S = np.asarray(data.S).reshape(6)
    lin, ang = S[:3], S[3:]
    if np.linalg.norm(lin) < 1e-12 and abs(np.linalg.norm(ang) - 1.0) < 1e-12:
        expected = pin.SE3(pin.AngleAxis(0.7, ang).matrix(), np.zeros(3))
        revolute, axis = True, ang
    elif np.linalg.norm(ang) < 1e-12 and abs(np.linalg.norm(lin) - 1.0) < 1e-12:
        expected = pin.SE3(np.eye(3), 0.7 * lin)
        revolute, axis = False, lin
    else:
        return None
    if not np.allclose(data.M.homogeneous, expected.homogeneous, rtol=0, atol=1e-12):
        return None
    return revolute, axis.copy()
