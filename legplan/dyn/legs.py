"""Where a leg's collision spheres are, given its foot: the robot's own kinematics, for any leg chain.

The centroidal model (`legplan.dyn`) plans the base and the feet, not the joints; to keep the legs
themselves off the terrain (`constraints.LegClearanceBlock`) it needs each leg's collision spheres
as a function of the foot's position b in the base frame, and that function's Jacobian. `ChainLegs`
reads every leg's chain from the robot's pinocchio model once — per joint its placement in its
parent joint's frame (`Model.jointPlacements`) and its rotation axis in its own frame; per sphere
and per foot the joint that carries it and the offset in that joint's frame — and evaluates the
chain for many samples at once:

* forward kinematics: T_j = T_{j−1} M_j Rot(a_j, q_j) from the base (Rodrigues' formula about the
  joint's unit axis), points x = T_j x_local;
* inverse kinematics from the foot: damped Gauss–Newton on the joints, q ← q + Jᵀ(J Jᵀ + λI)⁻¹(b − x_foot(q))
  (a step scaled down to at most `IK_STEP` per joint),
  started from the previous solution of the same samples (the nominal joints at first); a
  solution outside the robot's planning joint limits (a far target can carry the damped steps
  through the stretched leg, and the knee then bends the other way, which the robot cannot) is
  solved again from the nominal joints, so the knee keeps the side of the nominal stance, the
  side the independent check's IK (`legplan.robots.legik`) and the robot take; a block keeps that
  solution in its `LegIKData` workspace (Pinocchio's data beside the immutable chain) with the
  frames, the foot's point and Jacobian and the damped pseudo-inverse there, so the next solve's
  first iteration reads them instead of computing them again (the same numbers). Where the leg
  has the planar closed form (`PlanarLegs.joints`: an HAA/HFE/KFE leg, knee on the nominal side)
  the iteration starts from its joints instead: they meet the IK's tolerance at once (one
  kinematics evaluation, which the foot's Jacobian needs anyway) or after a Newton step or two
  where round-off or a slightly tilted axis leaves more, and land on the solution the warm start
  keeps. A foot out of the closed form's reach starts from the previous solution as before (the
  chain's least-squares answer). One difference: on a leg whose planning limits admit the knee
  bent both ways, a warm start the damped steps carried across keeps the flipped knee, which the
  closed form does not follow;
* derivative of a sphere centre s(q(b)) by the implicit function theorem: ∂s/∂b = J_s ∂q/∂b with
  ∂q/∂b = J_fᵀ(J_f J_fᵀ)⁻¹ (J_f⁻¹ for a three-joint leg), J_s and J_f the point Jacobians
  a_j × (x − p_j) of the joints up to the point's own.

Revolute joints only (a prismatic or a non-serial leg: `of_robot` returns None). The planar closed
form (`legplan.robots.planar_legs`) gives the same spheres for HAA/HFE/KFE legs; this serves every
leg the URDF describes (hip offsets, tilted axes, more than three joints).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass, replace

import numpy as np
import pinocchio as pin

from legplan.dyn.euler import cross
from legplan.robots.kinematics import one_dof_axis
from legplan.robots.planar_legs import PlanarLegs
from legplan.robots.so3 import skew

IK_ITERATIONS = 30
IK_TOLERANCE = 1e-13  # m: foot position error at which the IK stops (Newton: one step more than 1e-10)
IK_DAMPING = 1e-10  # λ of the damped steps (m²): only where the leg is stretched or folded flat
IK_STEP = 0.5  # rad: the largest joint step of an IK iteration (a far target: Gauss–Newton overshoots)


@dataclass(frozen=True)
class _Chain:
    """One leg: per joint (root to tip) its placement in the parent joint (rotation, translation)
    and its axis in its own frame; the foot's joint index and offset; per sphere its joint index,
    offset and radius; the nominal joint angles."""

    rotations: np.ndarray     # (J, 3, 3)
    translations: np.ndarray  # (J, 3)
    axes: np.ndarray          # (J, 3)
    foot_joint: int
    foot_offset: np.ndarray   # (3,)
    sphere_joint: np.ndarray  # (K,)
    sphere_offset: np.ndarray  # (K, 3)
    sphere_radius: np.ndarray  # (K,)
    nominal: np.ndarray       # (J,)
    lower: np.ndarray         # (J,) planning joint limits
    upper: np.ndarray         # (J,)
    closed_form: object = None  # feet (n, 3) -> joints (n, J), NaN rows out of its reach (`PlanarLegs.joints`)

    def kinematics(self, q: np.ndarray):
        """Joint frames for joints q (n, J): origins (n, J, 3), rotations (n, J, 3, 3) in the base
        frame, and the world axes (n, J, 3). Joint j's rotation R_j = R_{j−1} M_j Rot(a_j, q_j) with
        Rodrigues' Rot(a, q) = I + sin q [a]× + (1 − cos q) [a]×² (unit a), its origin
        o_j = o_{j−1} + R_{j−1} t_j and its axis R_j a_j = R_{j−1} M_j a_j: every term R_{j−1} times a
        constant of the chain (`_products`), one matrix product per joint for all samples."""
        n, count = q.shape
        origin, rot, axes = np.empty((n, count, 3)), np.empty((n, count, 3, 3)), np.empty((n, count, 3))
        s, c = np.sin(q), 1.0 - np.cos(q)
        for j, constants in enumerate(self._products):
            if j == 0:  # R_{−1} = I: the constants themselves
                terms, origin[:, 0] = np.broadcast_to(constants, (n, 3, 11)), self.translations[0]
            else:
                terms = (rot[:, j - 1].reshape(-1, 3) @ constants).reshape(n, 3, 11)
                origin[:, j] = origin[:, j - 1] + terms[:, :, 10]
            rot[:, j] = terms[:, :, 0:3] + s[:, j, None, None] * terms[:, :, 3:6] + c[:, j, None, None] * terms[:, :, 6:9]
            axes[:, j] = terms[:, :, 9]
        return origin, rot, axes

    @functools.cached_property
    def _products(self) -> list[np.ndarray]:
        """Per joint the (3, 11) constants [M_j | M_j[a_j]× | M_j[a_j]×² | M_j a_j | t_j] of `kinematics`."""
        k = skew(self.axes)
        return [np.hstack([m, m @ kj, m @ kj @ kj, (m @ a)[:, None], t[:, None]])
                for m, kj, a, t in zip(self.rotations, k, self.axes, self.translations)]

    def point(self, frames, joint: int, offset: np.ndarray):
        """A point fixed to `joint` at `offset` (its frame): position (n, 3) and Jacobian (n, 3, J)."""
        origin, rot, axes = frames
        x = origin[:, joint] + rot[:, joint] @ offset
        jac = np.zeros(x.shape + (origin.shape[1],))
        jac[:, :, :joint + 1] = np.swapaxes(cross(axes[:, :joint + 1], x[:, None] - origin[:, :joint + 1]), 1, 2)
        return x, jac

    def solve(self, feet: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Joints (n, J) that put the foot at `feet` (n, 3, base frame), from q (n, J)."""
        return self.solve_frames(feet, q)[0]

    def solve_frames(self, feet: np.ndarray, start):
        """`solve`'s joints q with their `kinematics` frames and the foot's `point` (position,
        Jacobian) there: those of the IK's last iterate when it converged, computed again when it
        did not. `start`: the first joints (n, J), or a `LegIKData` workspace, which the IK starts
        from (its first iteration at its cached frames) and leaves holding this solve. Samples
        whose joints leave the planning limits are solved again from the nominal joints (module
        docstring)."""
        data = start if isinstance(start, LegIKData) else LegIKData(np.asarray(start, float))
        if self.closed_form is not None:
            closed = self.closed_form(feet)
            reached = np.isfinite(closed).all(axis=1)
            if reached.any():  # start there (module docstring); the cached frames are the old start's
                data.keep(np.where(reached[:, None], closed, data.q), None, None, None, None)
        q, frames, x, jac = self._iterate(feet, data)
        outside = ((q < self.lower) | (q > self.upper)).any(axis=1)
        if outside.any():
            again = self._iterate(feet[outside], LegIKData(np.tile(self.nominal, (int(outside.sum()), 1))))
            for whole, part in zip((q, *frames, x, jac), (again[0], *again[1], again[2], again[3])):
                whole[outside] = part
            data.keep(q, frames, x, jac, None)
        return q, frames, x, jac

    def _iterate(self, feet: np.ndarray, data: LegIKData):
        """Damped Gauss–Newton from the workspace's joints: (joints, frames, foot position, foot
        Jacobian), kept in the workspace."""
        q = data.q.copy()
        cached = data.frames is not None
        for _ in range(IK_ITERATIONS):
            if cached:  # the last solve's kinematics at these very joints
                frames, x, jac, pinv = data.frames, data.foot, data.jac, data.pinv
                cached = False
            else:
                frames = self.kinematics(q)
                x, jac = self.point(frames, self.foot_joint, self.foot_offset)
                pinv = None
            error = feet - x
            if np.abs(error).max(initial=0.0) < IK_TOLERANCE:
                data.keep(q, frames, x, jac, pinv)
                return q, frames, x, jac
            step = ((_damped_pinv(jac) if pinv is None else pinv) @ error[..., None])[..., 0]
            q += step * np.minimum(1.0, IK_STEP / np.maximum(np.abs(step).max(axis=1, keepdims=True), 1e-300))
        frames = self.kinematics(q)
        x, jac = self.point(frames, self.foot_joint, self.foot_offset)
        data.keep(q, frames, x, jac, None)
        return q, frames, x, jac


class LegIKData:
    """The IK workspace of one leg's samples in one block (the chain itself stays immutable): the
    joints of the last solve, which the next one starts from (the nominal joints at first), and
    the chain's frames, the foot's point and Jacobian, and its damped pseudo-inverse (once asked
    for, `pinv_of`) at those joints."""

    def __init__(self, q: np.ndarray):
        self.q = q
        self.frames = self.foot = self.jac = self.pinv = None

    def keep(self, q, frames, foot, jac, pinv) -> None:
        self.q, self.frames, self.foot, self.jac, self.pinv = q, frames, foot, jac, pinv

    def pinv_of(self, jac: np.ndarray) -> np.ndarray:
        """`_damped_pinv(jac)`, kept for the next solve when `jac` is the workspace's own."""
        if jac is not self.jac:
            return _damped_pinv(jac)
        if self.pinv is None:
            self.pinv = _damped_pinv(jac)
        return self.pinv


class ChainLegs:
    """Every leg's chain of a robot (module docstring); spheres numbered over all legs."""

    def __init__(self, chains: list[_Chain]):
        self.chains = chains
        self.sphere_leg = np.concatenate([np.full(c.sphere_radius.size, k) for k, c in enumerate(chains)]).astype(int)
        self.sphere_radius = np.concatenate([c.sphere_radius for c in chains])

    @classmethod
    def of_robot(cls, robot, closed_form: bool = True) -> ChainLegs | None:
        """The chains of a `RobotModel` (legs in its order); None unless every leg is a serial
        chain of revolute joints from the base carrying its foot. With `closed_form` the IK starts
        from the planar closed form where the legs have one (`PlanarLegs.of_robot` of the joints
        alone, wherever the collision spheres sit; module docstring)."""
        model = robot.model
        neutral = pin.neutral(model)
        spheres = robot.spheres
        chains = []
        for k, leg in enumerate(robot.legs):
            ids = [model.getJointId(name) for name in leg.joint_names]
            parents = [model.parents[i] for i in ids]
            if parents[0] != 1 or any(p != i for p, i in zip(parents[1:], ids[:-1])):
                return None
            kinds = [one_dof_axis(model.joints[i], neutral) for i in ids]
            axes = [kind[1] if kind is not None and kind[0] else None for kind in kinds]
            if any(a is None for a in axes):
                return None
            foot = model.frames[leg.foot_frame_id]
            if foot.parentJoint not in ids:
                return None
            picked = [s for s in np.flatnonzero(np.asarray(spheres.leg_index) == k)
                      if not spheres.is_foot[s] and model.frames[int(spheres.frame_ids[s])].parentJoint in ids]
            frames = [model.frames[int(spheres.frame_ids[s])] for s in picked]
            chains.append(_Chain(
                rotations=np.array([model.jointPlacements[i].rotation for i in ids]),
                translations=np.array([model.jointPlacements[i].translation for i in ids]),
                axes=np.array(axes), foot_joint=ids.index(foot.parentJoint),
                foot_offset=np.array(foot.placement.translation),
                sphere_joint=np.array([ids.index(f.parentJoint) for f in frames], int),
                sphere_offset=np.array([f.placement.act(np.asarray(spheres.offsets[s], float))
                                        for f, s in zip(frames, picked)]).reshape(-1, 3),
                sphere_radius=np.asarray(spheres.radii, float)[picked],
                nominal=np.array([robot.q_nominal[model.idx_qs[i]] for i in ids]),
                lower=np.array([robot.lower[model.idx_qs[i] - 7] for i in ids]),
                upper=np.array([robot.upper[model.idx_qs[i] - 7] for i in ids])))
        planar = PlanarLegs.of_robot(robot, spheres=False) if closed_form else None
        if planar is not None:
            chains = [replace(c, closed_form=functools.partial(planar.joints, k)) for k, c in enumerate(chains)]
        return cls(chains)

    def spheres_of(self, leg: int) -> np.ndarray:
        """Indices (into `sphere_radius`) of the spheres of one leg."""
        return np.flatnonzero(self.sphere_leg == leg)

    def nominal(self, leg: int, n: int) -> np.ndarray:
        """The nominal joints of a leg for n samples (an IK start)."""
        return np.tile(self.chains[leg].nominal, (n, 1))

    def workspace(self, leg: int, n: int) -> LegIKData:
        """An IK workspace for n samples of a leg, starting from its nominal joints."""
        return LegIKData(self.nominal(leg, n))

    def foot_torques(self, leg: int, feet: np.ndarray, forces: np.ndarray, q, derivatives: bool = True):
        """Joint torques τ = J_fᵀ g (n, J) that hold the leg's foot at `feet` (n, 3, base frame)
        against forces g (n, 3, base frame) at the foot, J_f the foot's point Jacobian at the joints
        of the IK started from q (n, J, or a `LegIKData` workspace) (statics: the torque the joints give for the force, legs
        without mass); ∂τ/∂foot (n, J, 3) by the implicit function theorem through the IK,
        ∂τ/∂g = J_fᵀ (n, J, 3) (both None without `derivatives`: a residual alone), and the joints
        (n, J). With r_i = x − o_i (x the foot, o_i joint i's origin), a_i its axis and c_i = a_i × r_i
        the foot Jacobian's column, τ_i = g · c_i; a turn of joint k < i turns a_i and r_i about a_k
        (∂c_i/∂q_k = a_k × c_i), of k ≥ i moves x alone (a_i × (a_k × r_k) = a_i × c_k), so
        ∂τ_i/∂q_k = a_min(i,k) · (c_max(i,k) × g): the upper triangle of m_pq = a_p · (c_q × g),
        mirrored. Columns past the foot's joint are zero, and so are their rows and columns here."""
        chain = self.chains[leg]
        data = q if isinstance(q, LegIKData) else LegIKData(np.asarray(q, float))
        q, (_, _, axes), _, jac = chain.solve_frames(np.asarray(feet, float), data)
        forces = np.asarray(forces, float)
        tau = np.einsum("nai,na->ni", jac, forces)
        if not derivatives:
            return tau, None, None, q
        columns = np.swapaxes(jac, 1, 2)  # (n, J, 3): c_i
        m = axes @ np.swapaxes(cross(columns, forces[:, None]), 1, 2)  # [n, p, q] = a_p · (c_q × g)
        d_tau_dq = np.triu(m) + np.swapaxes(np.triu(m, 1), 1, 2)  # (n, i, k)
        return tau, d_tau_dq @ data.pinv_of(jac), columns, q

    def sphere_centres(self, leg: int, feet: np.ndarray, q: np.ndarray):
        """Centres (n, k, 3) of the leg's k spheres in the base frame with its foot at `feet` (n, 3,
        base frame), their Jacobians ∂centre/∂foot (n, k, 3, 3), and the joints (n, J) of the IK
        started from q (n, J, or a `LegIKData` workspace)."""
        chain = self.chains[leg]
        data = q if isinstance(q, LegIKData) else LegIKData(np.asarray(q, float))
        q, frames, _, foot_jac = chain.solve_frames(np.asarray(feet, float), data)
        dq = data.pinv_of(foot_jac)  # (n, J, 3): ∂q/∂foot
        centres, jacobians = [], []
        for joint, offset in zip(chain.sphere_joint, chain.sphere_offset):
            x, jac = chain.point(frames, int(joint), offset)
            centres.append(x)
            jacobians.append(jac @ dq)
        n = len(q)
        if not centres:
            return np.zeros((n, 0, 3)), np.zeros((n, 0, 3, 3)), q
        return np.stack(centres, axis=1), np.stack(jacobians, axis=1), q


def _damped_pinv(jac: np.ndarray) -> np.ndarray:
    """Jᵀ(J Jᵀ + λI)⁻¹ of Jacobians (n, 3, J)."""
    jt = np.swapaxes(jac, 1, 2)
    return jt @ _inverse3(jac @ jt + IK_DAMPING * np.eye(3))


def _inverse3(a: np.ndarray) -> np.ndarray:
    """Inverses (n, 3, 3) of symmetric positive definite 3 × 3 matrices (J Jᵀ + λI) by Cholesky,
    A = L Lᵀ, A⁻¹ = L⁻ᵀ L⁻¹, written out on n-vectors (LAPACK pays a call per matrix); backward
    stable like a pivoted LU, where the cofactor formula is not for a nearly singular A."""
    l00 = np.sqrt(a[:, 0, 0])
    l10, l20 = a[:, 1, 0] / l00, a[:, 2, 0] / l00
    l11 = np.sqrt(a[:, 1, 1] - l10 * l10)
    l21 = (a[:, 2, 1] - l20 * l10) / l11
    l22 = np.sqrt(a[:, 2, 2] - l20 * l20 - l21 * l21)
    m00, m11, m22 = 1.0 / l00, 1.0 / l11, 1.0 / l22  # M = L⁻¹, lower triangular
    m10 = -l10 * m00 * m11
    m21 = -l21 * m11 * m22
    m20 = -(l20 * m00 + l21 * m10) * m22
    out = np.empty_like(a)  # Mᵀ M
    out[:, 0, 0] = m00 * m00 + m10 * m10 + m20 * m20
    out[:, 1, 1] = m11 * m11 + m21 * m21
    out[:, 2, 2] = m22 * m22
    out[:, 0, 1] = out[:, 1, 0] = m10 * m11 + m20 * m21
    out[:, 0, 2] = out[:, 2, 0] = m20 * m22
    out[:, 1, 2] = out[:, 2, 1] = m21 * m22
    return out
