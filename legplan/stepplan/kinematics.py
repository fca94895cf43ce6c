"""The step planner's batch kinematics: the points its constraints read, and their Jacobians in x.

The residuals of a step (`legplan.stepplan.block`) read the feet, the collision-sphere centres and
the CoM at every sample of the curve, and their Jacobians w.r.t. the vector x = [p, ω, joints] of
eq. (1b). Two providers give them through one interface (`points`, `jacobians`, `com_jacobian`):

* `ChainKinematics`: forward kinematics written out for a free-flyer tree of one-degree-of-freedom
  revolute or prismatic joints, vectorized over all samples at once and over all joints of one
  depth of the tree (the legs' hips, then their knees, ...), from the pinocchio model's joint
  placements and motion axes (nothing is parsed again). A joint of depth l is placed at
  ᵒMⱼ = ᵒM_parent · M_j · exp(S_j q_j): for a revolute joint of axis a, exp = I + sin q [a]× +
  (1 − cos q) [a]×². The Jacobians are formed in x directly and only for the points asked for:

      ∂p/∂p_base = I,   ∂p/∂ω = −[p − p_base]× J_l(ω),   ∂p/∂q_k = a_k × (p − o_k) (revolute) or a_k,

  with J_l the left Jacobian of exp on SO(3) (exp(ω + δ) ≈ exp(J_l δ) exp(ω)), a_k, o_k the world
  axis and origin of each joint k supporting p. The CoM Jacobian's joint columns are a_k × Σ w_b
  (c_b − o_k) over the bodies b that joint k moves (w_b = m_b / M).
* `RobotPoints`: any robot with the batch interface of `legplan.robots.RobotModel` (pinocchio
  FK per configuration, J_x = J_v · tangent_map) — the fallback for trees `ChainKinematics` does not
  cover, and for test robots.

The independent check (`legplan.validate`) uses neither: it runs pinocchio's own FK.
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass

import numpy as np

from legplan.robots.kinematics import one_dof_axis
from legplan.robots.so3 import right_jacobian, rotvec_to_matrix, skew


@dataclass
class Points:
    """Feet (n, n_legs, 3), sphere centres (n, n_spheres, 3) and CoM (n, 3) at vectors X (n, nx), and what the
    provider keeps to form their Jacobians (`state`)."""

    X: np.ndarray
    feet: np.ndarray
    spheres: np.ndarray
    com: np.ndarray
    state: object = None


@dataclass(frozen=True)
class _Level:
    """The joints of one depth of the tree: slots start..stop, hanging from the level above."""

    start: int
    stop: int
    parents: np.ndarray | None  # their parents' positions in the level above; None: the same order


class ChainKinematics:
    """Batch forward kinematics of `robot` (a `RobotModel`) written out over its joint tree; see the
    module docstring. Build it with `of`, which says None for a tree it does not cover.

    Placements are kept as (…, 3, 4) = [R | t], level by level of the tree (the base, its children, their
    children, ...), in "slots" (the joints in level order). The local placement of every joint,
    M_j·exp(S_j q_j), is F + sin q · B + (1 − cos q) · C + q · D with the constant F = [R_j | t_j],
    B = [R_j [a]× | 0], C = [R_j [a]×² | 0] (revolute joints) and D = [0 | R_j a] (prismatic joints).
    Every point the rows read (feet, sphere centres, the CoM and, per joint, the mass-weighted sum of the
    body CoMs it moves) is one column of a constant matrix `_attach` (4·slots, points): all of them
    are one product of the stacked placements with it.
    """

    def __init__(self, robot, levels, local, slot, axes, revolute, columns):
        from legplan.robots.kinematics import AttachedPoints

        model = robot.model
        self.nx = robot.nv
        self._levels = levels
        self._local = local  # (F, B, C, D or None) (slots − 1, 3, 4) of slots 1, 2, ..., and their x entries
        F, B, C, D, _ = local  # per slot the rows (B, C, F[, D]) of its local placement's coefficients
        self._basis = np.stack([B, C, F] + ([] if D is None else [D]), axis=1).reshape(len(F), -1, 12)
        nj = model.njoints
        self._slot = slot  # (njoints,) slot of each joint (universe: −1)
        slots = int(slot.max()) + 1
        feet = AttachedPoints.of_frames(model, [leg.foot_frame_id for leg in robot.legs])
        spheres = AttachedPoints.of_frames(model, robot.spheres.frame_ids, robot.spheres.offsets)
        bodies = AttachedPoints.of_body_coms(model)
        self._n_feet, self._n_points = len(feet.joints), len(feet.joints) + len(spheres.joints)
        masses = np.array([model.inertias[int(j)].mass for j in bodies.joints])
        total = masses.sum()
        weights = masses / total if total > 0 else np.full_like(masses, np.nan)
        # the joints with an entry in x, and per joint the weights of the bodies it moves (CoM Jacobian)
        self._joints = np.flatnonzero(columns >= 0)
        self._joint_columns = columns[self._joints]
        moved = np.zeros((nj, len(bodies.joints)))
        for b, j in enumerate(bodies.joints):
            moved[list(model.supports[int(j)]), b] = weights[b]
        self._moved_weight = moved[self._joints].sum(axis=1)
        # columns of `_attach`: feet, spheres, then the CoM; of `_moved`: per joint of x, the mass-weighted sum
        # of the CoMs of the bodies it moves (the CoM Jacobian's joint columns)
        attach = np.zeros((slots, 4, self._n_points + 1))
        for p, (j, o) in enumerate(zip(np.concatenate([feet.joints, spheres.joints]),
                                       np.concatenate([feet.offsets, spheres.offsets]))):
            attach[slot[j], :, p] = [*o, 1.0]
        sums = np.zeros((slots, 4, 1 + len(self._joints)))
        for column, k in enumerate([1, *self._joints]):
            for b, j in enumerate(bodies.joints):
                sums[slot[j], :, column] += moved[k, b] * np.array([*bodies.offsets[b], 1.0])
        attach[..., -1] = sums[..., 0]
        self._attach = attach.reshape(slots * 4, -1)
        self._moved = sums[..., 1:].reshape(slots * 4, -1)
        self._axes = axes[self._joints]  # (J, 3) in the joint frames
        self._revolute = revolute
        # per point (feet, spheres): the slots and x entries of its supporting joints with an entry in x,
        # padded with slot 0 and the scratch column nx
        point_joints = np.concatenate([feet.joints, spheres.joints]).astype(np.intp)
        chains = [[k for k in model.supports[int(j)] if columns[k] >= 0] for j in point_joints]
        depth = max(max((len(c) for c in chains), default=0), 1)
        self._chain_slot = np.zeros((len(chains), depth), np.intp)
        self._chain_axis = np.zeros((len(chains), depth, 3))
        self._chain_revolute = np.zeros((len(chains), depth), bool)
        self._chain_column = np.full((len(chains), depth), self.nx, np.intp)
        for p, chain in enumerate(chains):
            d = len(chain)
            self._chain_slot[p, :d] = slot[chain]
            self._chain_axis[p, :d] = axes[chain]
            self._chain_revolute[p, :d] = revolute[chain]
            self._chain_column[p, :d] = columns[chain]

    @classmethod
    def of(cls, robot) -> ChainKinematics | None:
        """The written-out kinematics of `robot`, or None if its tree is not a free flyer at an
        identity placement carrying one-degree-of-freedom revolute/prismatic joints (then use `RobotPoints`)."""
        import pinocchio as pin

        model = getattr(robot, "model", None)
        if not isinstance(model, pin.Model) or model.njoints < 2:
            return None
        if model.joints[1].shortname() != "JointModelFreeFlyer" or model.parents[1] != 0 \
                or not model.jointPlacements[1].isIdentity() or robot.nv != model.nv or model.nq != model.nv + 1:
            return None
        nj = model.njoints
        axes, revolute = np.zeros((nj, 3)), np.zeros(nj, bool)
        columns = np.full(nj, -1, np.intp)
        depth = np.zeros(nj, int)
        q = pin.neutral(model)
        for j in range(2, nj):
            joint = model.joints[j]
            if joint.nq != 1 or joint.nv != 1 or model.parents[j] == 0:
                return None
            kind = one_dof_axis(joint, q)
            if kind is None:
                return None
            revolute[j], axes[j] = kind
            columns[j] = joint.idx_v
            depth[j] = depth[model.parents[j]] + 1
        # slots: the base, then the joints level by level, children in the order of their parents' slots
        # (so that the levels of a set of chains line up and need no gather)
        slot = np.full(nj, -1, np.intp)
        slot[1] = 0
        levels, above, parents = [], np.array([1]), np.asarray(model.parents)
        for d in range(1, depth.max(initial=0) + 1):
            joints = np.flatnonzero(depth == d)
            joints = joints[np.argsort(slot[parents[joints]], kind="stable")]
            order = np.argsort(above)
            position = order[np.searchsorted(above[order], parents[joints])]
            aligned = len(above) == 1 or np.array_equal(position, np.arange(len(joints)))
            start = int(slot.max()) + 1
            slot[joints] = start + np.arange(len(joints))
            levels.append(_Level(start, start + len(joints), None if aligned else position))
            above = joints
        by_slot = np.argsort(np.where(slot < 0, nj, slot))[1:int(slot.max()) + 1]  # joint of slots 1, 2, ...
        F, B, C, D = (np.zeros((len(by_slot), 3, 4)) for _ in range(4))
        for row, j in enumerate(by_slot):
            M, a = model.jointPlacements[int(j)], axes[j]
            F[row, :, :3], F[row, :, 3] = M.rotation, M.translation
            if revolute[j]:
                K = skew(a)
                B[row, :, :3] = M.rotation @ K
                C[row, :, :3] = M.rotation @ K @ K
            else:
                D[row, :, 3] = M.rotation @ a
        return cls(robot, levels, (F, B, C, D if (~revolute[2:]).any() else None, columns[by_slot]), slot, axes,
                   revolute, columns)

    def placements(self, X: np.ndarray) -> np.ndarray:
        """Placements [R | t] (n, slots, 3, 4) of the base (the identity) and every joint in the base frame,
        in slot order (a view of an (n, 3, slots, 4) array: row (sample, axis), column (slot, 4) for `points`). The local placements are one product per joint of the coefficients (sin q, 1 − cos q,
        1, q) with the stacked constants (B, C, F, D); a level is placed on its parents by the three
        rank-one terms of the 3 × 3 · 3 × 4 products (a batched matmul of so small matrices costs more),
        formed entry by entry over all joints of the level and all samples at once (layout (3, 4, joints,
        n)), so that every array operation runs over one long contiguous axis."""
        basis, columns = self._basis, self._local[4]
        q = X[:, columns].T  # (joints, n)
        n, count = len(X), len(columns)
        coefficients = np.empty((count, n, basis.shape[1]))
        np.sin(q, out=coefficients[..., 0])
        coefficients[..., 1] = 1.0 - np.cos(q)
        coefficients[..., 2] = 1.0
        if basis.shape[1] > 3:
            coefficients[..., 3] = q
        entries = np.ascontiguousarray((coefficients @ basis).reshape(count, n, 3, 4).transpose(2, 3, 0, 1))
        for above, level in zip(self._levels, self._levels[1:]):  # entries[:, :, j] is slot j + 1
            parent = entries[:, :, above.start - 1:above.stop - 1]
            if level.parents is not None:
                parent = parent[:, :, level.parents]
            local = entries[:, :, level.start - 1:level.stop - 1]
            world = parent[:, 0, None] * local[0]
            world += parent[:, 1, None] * local[1]
            world += parent[:, 2, None] * local[2]
            world[:, 3] += parent[:, 3]
            local[...] = world
        # one copy into the layout `points` multiplies with, (n, 3, slots, 4); T is a view of it
        stacked = np.empty((n, 3, count + 1, 4))
        stacked[:, :, 0] = np.eye(3, 4)
        stacked[:, :, 1:] = entries.transpose(3, 0, 2, 1)
        return stacked.transpose(0, 2, 1, 3)

    def points(self, X: np.ndarray) -> Points:
        """Feet, sphere centres and CoM at the vectors X (n, nx): the points in the base frame, one product
        of the stacked placements with `_attach`, then placed by the base, p = R(ω) p_b + p_base."""
        T = self.placements(X)
        n = len(X)
        stacked = T.transpose(0, 2, 1, 3).reshape(n * 3, -1)  # row (sample, axis), column (slot, 4): a view
        base = rotvec_to_matrix(X[:, 3:6])
        attached = (base @ (stacked @ self._attach).reshape(n, 3, -1) + X[:, :3, None]).transpose(0, 2, 1)
        f, p = self._n_feet, self._n_points
        return Points(X, attached[:, :f], attached[:, f:p], attached[:, p], _ChainState(T, stacked, base, attached))

    @staticmethod
    def _left_jacobians(points: Points) -> np.ndarray:
        """J_l(ω) = J_r(ω)ᵀ (n, 3, 3) of every sample, formed once per `Points`."""
        state = points.state
        if state.left is None:
            state.left = right_jacobian(points.X[:, 3:6]).transpose(0, 2, 1)
        return state.left

    def jacobians(self, points: Points, samples: np.ndarray, which: np.ndarray) -> np.ndarray:
        """Jacobians (K, 3, nx) of points `which` (K,) (feet 0..n_legs−1, then spheres) at samples (K,).
        The joint columns are formed in the base frame, a × (p − o), and rotated into the world."""
        state = points.state
        samples = np.asarray(samples, np.intp)
        which = np.asarray(which, np.intp)
        lever = state.attached[samples, which] - points.X[samples, :3]  # (K, 3) p − p_base
        out = np.zeros((len(samples), 3, self.nx + 1))  # the last column is scratch for padding
        out[:, 0, 0] = out[:, 1, 1] = out[:, 2, 2] = 1.0
        out[:, :, 3:6] = skew(-lever) @ self._left_jacobians(points)[samples]  # −[p − p_base]× J_l(ω)
        base = state.base[samples]
        frames = state.T[samples[:, None], self._chain_slot[which]]  # (K, D, 3, 4) in the base frame
        axis = (frames[..., :3] @ self._chain_axis[which][..., None])[..., 0]  # (K, D, 3)
        arm = (lever[:, None, :] @ base)[:, 0, None, :] - frames[..., 3]  # p − o in the base frame
        joint = np.where(self._chain_revolute[which][..., None], (skew(axis) @ arm[..., None])[..., 0], axis)
        out[np.arange(len(samples))[:, None], :, self._chain_column[which]] = joint @ base.transpose(0, 2, 1)
        return out[:, :, :self.nx]

    def com_jacobian(self, points: Points) -> np.ndarray:
        """CoM Jacobian (n, 3, nx): joint columns a_k × Σ w_b (c_b − o_k) over the bodies b joint k moves."""
        state = points.state
        X = points.X
        n = len(X)
        out = np.zeros((n, 3, self.nx))
        out[:, 0, 0] = out[:, 1, 1] = out[:, 2, 2] = 1.0
        out[:, :, 3:6] = skew(X[:, :3] - points.com) @ self._left_jacobians(points)
        frames = state.T[:, self._slot[self._joints]]  # (n, J, 3, 4) in the base frame
        axis = (frames[..., :3] @ self._axes[..., None])[..., 0]  # (n, J, 3)
        sums = (state.stacked @ self._moved).reshape(n, 3, -1).transpose(0, 2, 1)  # (n, J, 3)
        moved = sums - self._moved_weight[:, None] * frames[..., 3]
        joint = np.where(self._revolute[self._joints][:, None], (skew(axis) @ moved[..., None])[..., 0],
                         self._moved_weight[:, None] * axis)
        out[:, :, self._joint_columns] = state.base @ joint.transpose(0, 2, 1)
        return out


@dataclass
class _ChainState:
    """What `ChainKinematics.points` keeps for the Jacobians of the same samples."""

    T: np.ndarray  # (n, slots, 3, 4) placements in the base frame
    stacked: np.ndarray  # (3n, 4·slots) the same, one row per sample and axis
    base: np.ndarray  # (n, 3, 3) base orientation R(ω)
    attached: np.ndarray  # (n, points + 1, 3) feet, spheres, CoM in the world
    left: np.ndarray | None = None  # J_l(ω) (n, 3, 3), formed on first use


class RobotPoints:
    """The same interface over any robot with `RobotModel`'s batch calls (`kinematics`, `foot_positions`, ...,
    `tangent_map`): its own FK, Jacobians J_v · tangent_map."""

    def __init__(self, robot):
        self.robot = robot
        self.nx = robot.nv

    def points(self, X: np.ndarray) -> Points:
        robot = self.robot
        Q = robot.from_vector(X)
        robot.kinematics(Q, jacobians=False)
        return Points(X, robot.foot_positions(Q), robot.sphere_centres(Q), robot.com(Q), Q)

    def jacobians(self, points: Points, samples: np.ndarray, which: np.ndarray) -> np.ndarray:
        robot, Q = self.robot, points.state
        robot.kinematics(Q, jacobians=True)
        J = np.concatenate([robot.foot_jacobians(Q), robot.sphere_jacobians(Q)], axis=1)[samples, which]
        return np.einsum("kav,kvx->kax", J, robot.tangent_map(points.X)[samples])

    def com_jacobian(self, points: Points) -> np.ndarray:
        robot = self.robot
        return np.einsum("nav,nvx->nax", robot.com_jacobian(points.state), robot.tangent_map(points.X))


_BUILT: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # robot -> its ChainKinematics, or None


def planner_kinematics(robot):
    """`ChainKinematics` of `robot` where it covers its tree (built once per robot), else `RobotPoints`."""
    try:
        chain = _BUILT[robot]
    except (KeyError, TypeError):
        chain = ChainKinematics.of(robot)
        try:
            _BUILT[robot] = chain
        except TypeError:  # not weakly referenceable: built each time
            pass
    return chain or RobotPoints(robot)
