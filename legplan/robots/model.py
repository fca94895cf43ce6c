"""`RobotModel`: a legged robot with a free-flyer base, and its batch kinematics.

Pinocchio style: the model (pin.Model, legs, spheres, limits, nominal stance) is immutable; the
batch calls run on a workspace (`KinematicsWorkspace`, one pin.Data plus a one-batch cache).
Configurations Q are (n, nq) in pinocchio order [p, quaternion (x, y, z, w), joints]; tangent
vectors v are (nv,) [v_lin (base frame), ω (base frame), joint rates]; a single configuration
(nq,) is accepted and treated as n = 1 (results keep the leading n axis).

Vector parametrization of the Bézier planner (paper eq. (1b), SE(3) ≡ R^6):
x = [p (3), ω (3) rotation vector of the base orientation in the world, joints], nx = nv.
`tangent_map(X)` = dv/dx = blockdiag(Rᵀ, Jr(ω), I) so that J_x = J_v @ tangent_map(X).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pinocchio as pin

from legplan.robots.centroidal import Centroidal
from legplan.robots.kinematics import AttachedPoints, Kinematics, KinematicsWorkspace
from legplan.robots.planar_legs import PlanarLegs
from legplan.robots.so3 import quat_to_rotvec, right_jacobian, rotvec_to_matrix, rotvec_to_quat
from legplan.robots.spec import Leg, Navigation, RobotSpec, SphereSet


def chain_length(model: pin.Model, joint_ids, foot_frame_id: int) -> float:
    """Length of a leg chain: the distances between consecutive joint origins, plus the last joint
    to the foot frame (m)."""
    segments = [model.jointPlacements[j].translation for j in joint_ids[1:]]
    segments.append(model.frames[foot_frame_id].placement.translation)
    return sum(float(np.linalg.norm(v)) for v in segments)


class RobotModel:
    """A validated robot (see `legplan.robots.spec` for robot.yaml) with batch kinematics."""

    def __init__(self, spec: RobotSpec):
        self._spec = spec
        model = spec.model
        self.name: str = spec.name
        self.description: str = spec.description
        self.yaml_path: Path = spec.yaml_path
        self.urdf_path: Path = spec.urdf_path
        self.model: pin.Model = model
        self.nq: int = model.nq
        self.nv: int = model.nv
        self.nx: int = model.nv
        self.n_joints: int = model.nv - 6
        self.legs: tuple[Leg, ...] = spec.legs
        self.joint_names: tuple[str, ...] = tuple(model.names[2:])
        self.lower: np.ndarray = spec.lower
        self.upper: np.ndarray = spec.upper
        self.spheres: SphereSet = spec.spheres
        self.q_nominal: np.ndarray = spec.q_nominal
        self.navigation: Navigation | None = spec.navigation
        self.mass: float = float(pin.computeTotalMass(model))
        self._feet = AttachedPoints.of_frames(model, [leg.foot_frame_id for leg in spec.legs])
        self._sphere_points = AttachedPoints.of_frames(model, spec.spheres.frame_ids, spec.spheres.offsets)
        self._workspace: KinematicsWorkspace | None = None
        self.centroidal: Centroidal | None = None if spec.centroidal is None else \
            replace(spec.centroidal, leg_kinematics=PlanarLegs.of_robot(self))

    def __repr__(self) -> str:
        return (f"RobotModel({self.name!r}, nq={self.nq}, nv={self.nv}, legs={len(self.legs)}, "
                f"spheres={len(self.spheres)}, mass={self.mass:.3g} kg)")

    def __reduce__(self):
        # Pickle as "load it again": the workspace (pin.Data) is per process.
        from legplan.robots.registry import load_robot
        return load_robot, (self.yaml_path,)

    @property
    def n_legs(self) -> int:
        return len(self.legs)

    @property
    def leg_length(self) -> float:
        """Mean `chain_length` of the legs (m; the robot's size for size-scaled defaults)."""
        return float(np.mean([chain_length(self.model, [self.model.getJointId(name) for name in leg.joint_names],
                                           leg.foot_frame_id) for leg in self.legs]))

    @property
    def workspace(self) -> KinematicsWorkspace:
        """The workspace the batch calls use (created on first use)."""
        if self._workspace is None:
            self._workspace = KinematicsWorkspace(self.model, self._feet, self._sphere_points)
        return self._workspace

    # -- batch kinematics -------------------------------------------------------------------
    def _configurations(self, Q) -> np.ndarray:
        Q = np.atleast_2d(np.asarray(Q, float))
        if Q.ndim != 2 or Q.shape[1] != self.nq:
            raise ValueError(f"{self.name}: configurations must be (n, {self.nq}), got {Q.shape}")
        return Q

    def kinematics(self, Q, jacobians: bool = True) -> Kinematics:
        """Feet, sphere centres, CoM and (if `jacobians`) their Jacobians in one pass over Q."""
        return self.workspace.evaluate(self._configurations(Q), jacobians)

    def feet(self, Q, jacobians: bool = True) -> tuple[np.ndarray, np.ndarray | None]:
        """Foot positions (n, n_legs, 3) and (if `jacobians`) Jacobians (n, n_legs, 3, nv) alone, without
        the spheres and the CoM: what leg IK needs (`KinematicsWorkspace.feet`)."""
        return self.workspace.feet(self._configurations(Q), jacobians)

    def foot_positions(self, Q) -> np.ndarray:
        """(n, n_legs, 3) world positions of the foot frames."""
        return self.kinematics(Q, jacobians=False).foot_positions

    def foot_jacobians(self, Q) -> np.ndarray:
        """(n, n_legs, 3, nv) foot-point Jacobians, LOCAL_WORLD_ALIGNED, w.r.t. the tangent v."""
        return self.kinematics(Q).foot_jacobians

    def sphere_centres(self, Q) -> np.ndarray:
        """(n, n_spheres, 3) world positions of the collision sphere centres."""
        return self.kinematics(Q, jacobians=False).sphere_centres

    def sphere_jacobians(self, Q) -> np.ndarray:
        """(n, n_spheres, 3, nv) sphere-centre Jacobians w.r.t. v."""
        return self.kinematics(Q).sphere_jacobians

    def com(self, Q) -> np.ndarray:
        """(n, 3) centre of mass of the whole robot."""
        return self.kinematics(Q, jacobians=False).com

    def com_jacobian(self, Q) -> np.ndarray:
        """(n, 3, nv) CoM Jacobian w.r.t. v (= pin.jacobianCenterOfMass)."""
        return self.kinematics(Q).com_jacobian

    # -- vector parametrization (eq. (1b)) ----------------------------------------------------
    def to_vector(self, Q) -> np.ndarray:
        """(n, nq) configurations -> (n, nx) vectors x = [p, ω, joints], |ω| <= π."""
        Q = self._configurations(Q)
        return np.concatenate([Q[:, :3], quat_to_rotvec(Q[:, 3:7]), Q[:, 7:]], axis=1)

    def from_vector(self, X) -> np.ndarray:
        """(n, nx) vectors x = [p, ω, joints] -> (n, nq) configurations (unit quaternions)."""
        X = self._vectors(X)
        return np.concatenate([X[:, :3], rotvec_to_quat(X[:, 3:6]), X[:, 6:]], axis=1)

    def tangent_map(self, X) -> np.ndarray:
        """(n, nv, nx) dv/dx = blockdiag(R(ω)ᵀ, Jr(ω), I): J_x = J_v @ tangent_map(X)."""
        X = self._vectors(X)
        out = np.zeros((len(X), self.nv, self.nx))
        omega = X[:, 3:6]
        out[:, :3, :3] = np.swapaxes(rotvec_to_matrix(omega), 1, 2)
        out[:, 3:6, 3:6] = right_jacobian(omega)
        idx = np.arange(6, self.nv)
        out[:, idx, idx] = 1.0
        return out

    def _vectors(self, X) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, float))
        if X.ndim != 2 or X.shape[1] != self.nx:
            raise ValueError(f"{self.name}: vectors must be (n, {self.nx}), got {X.shape}")
        return X
