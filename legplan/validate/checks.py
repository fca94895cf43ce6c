"""Independent checks of whole-body configurations: pinocchio FK and FCL, not the planners' code.

Nothing here calls the robot layer's batch kinematics or the terrain SDF that the planners
optimise against. Kinematics come from `pin.framesForwardKinematics` / `data.oMf` /
`pin.centerOfMass` on the robot's pinocchio model; the terrain is the heightmap triangulated into an
FCL mesh (`SurfaceMesh`). The constraints checked are those of the Bézier paper Sec. II-B:
stance feet on their footholds (kinematic constraint, eq. (4a)), CoM above the support polygon
(stability) and collision spheres clear of the terrain (eq. (4b)), plus the joint limits.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from legplan.geometry.polygon import support_polygon
from legplan.validate.surface import SurfaceMesh


@dataclass
class ConfigChecks:
    """Per-configuration results of `Validator.check` for n configurations and L legs.

    foot_positions (n, L, 3) m; foot_gap (n, L) signed distance of each stance foot to the terrain
    surface (NaN for swing legs); foot_slip (n, L) distance of each stance foot to its given foothold
    (NaN for swing legs or when no footholds were given); com (n, 3); com_margin (n,) signed distance
    of the CoM (x, y) to the support polygon edges, positive inside (-inf with fewer than two distinct
    stance feet); clearance (n,) smallest sphere-to-terrain distance (surface distance of the centre
    minus radius) over all spheres except stance-foot spheres, with `clearance_sphere` (n,) its
    index; joint_excess (n, J) rad by which each joint leaves its limits (0 inside); sphere_centres
    (n, S, 3) the collision sphere centres.
    """

    foot_positions: np.ndarray
    foot_gap: np.ndarray
    foot_slip: np.ndarray
    com: np.ndarray
    com_margin: np.ndarray
    clearance: np.ndarray
    clearance_sphere: np.ndarray
    joint_excess: np.ndarray
    sphere_centres: np.ndarray

    @property
    def worst_foot_gap(self) -> np.ndarray:
        """(n,) largest |foot_gap| over stance legs (0 when none)."""
        return np.nanmax(np.abs(np.nan_to_num(self.foot_gap, nan=0.0)), axis=1, initial=0.0)

    def valid(self, foot_tolerance: float = 1e-3, com_margin: float = 0.0,
              clearance: float = 0.0, joint_tolerance: float = 1e-9) -> np.ndarray:
        """(n,) True where every check passes with the given tolerances (m, m, m, rad)."""
        slip = np.nan_to_num(self.foot_slip, nan=0.0).max(axis=1, initial=0.0)
        return ((self.worst_foot_gap <= foot_tolerance) & (slip <= foot_tolerance)
                & (self.com_margin >= com_margin) & (self.clearance >= clearance)
                & (self.joint_excess.max(axis=1, initial=0.0) <= joint_tolerance))


class Validator:
    """Checks configurations of `robot` on the terrain heightmap of `terrain` (mesh built once)."""

    def __init__(self, robot, terrain, *, surface: SurfaceMesh | None = None):
        self.robot = robot
        self.model = robot.model
        self.data = self.model.createData()
        self.surface = surface or SurfaceMesh(terrain.height, terrain.grid.origin, terrain.grid.resolution)
        spheres = robot.spheres
        foot_frames = [leg.foot_frame_id for leg in robot.legs]
        self._frames_all, slots = np.unique(np.r_[foot_frames, np.asarray(spheres.frame_ids, int)],
                                            return_inverse=True)
        self._frames_all = [int(f) for f in self._frames_all]
        self._foot_slot, self._sphere_slot = slots[:len(foot_frames)], slots[len(foot_frames):]
        self._offsets = np.asarray(spheres.offsets, float)
        self._radii = np.asarray(spheres.radii, float)
        self._sphere_leg = np.asarray(spheres.leg_index, int)
        self._sphere_is_foot = np.asarray(spheres.is_foot, bool)
        self._n_legs = len(foot_frames)
        self._joint_q = _actuated_q_indices(self.model, robot.joint_names)
        self._lower = np.asarray(robot.lower, float)
        self._upper = np.asarray(robot.upper, float)

    def kinematics(self, Q):
        """Foot positions (n, L, 3), sphere centres (n, S, 3) and CoM (n, 3) by pinocchio FK: one joint
        pass per configuration, then the placements of the frames the check reads and the CoM from
        it (`pin.updateFramePlacement`, `pin.centerOfMass` on the joint placements in `data`)."""
        Q = np.atleast_2d(np.asarray(Q, float))
        n = len(Q)
        frames = self._frames_all
        placements = np.empty((n, len(frames), 4, 4))
        com = np.empty((n, 3))
        model, data = self.model, self.data
        forward, place, centre = pin.forwardKinematics, pin.updateFramePlacement, pin.centerOfMass
        for i, q in enumerate(Q):
            forward(model, data, q)
            placements[i] = [place(model, data, f).homogeneous for f in frames]
            com[i] = centre(model, data, pin.KinematicLevel.POSITION, False)
        feet = placements[:, self._foot_slot][..., :3, 3]
        sph = placements[:, self._sphere_slot]
        centres = np.einsum("nsij,sj->nsi", sph[..., :3, :3], self._offsets) + sph[..., :3, 3]
        return feet, centres, com

    def check(self, Q, stance, footholds=None) -> ConfigChecks:
        """Check configurations Q (n, nq) (pinocchio order) with stance flags (n, L) or (L,) bool.

        `footholds` (n, L, 3) or (L, 3) (NaN rows allowed) are the assigned stance footholds; without them the
        support polygon is spanned by the stance feet themselves and foot_slip is NaN.
        """
        Q = np.atleast_2d(np.asarray(Q, float))
        n = len(Q)
        stance = np.broadcast_to(np.asarray(stance, bool), (n, self._n_legs))
        feet, centres, com = self.kinematics(Q)
        gap = np.full(stance.shape, np.nan)
        if stance.any():
            gap[stance] = self.surface.signed_distance(feet[stance])
        slip = np.full(stance.shape, np.nan)
        anchors = feet
        if footholds is not None:
            footholds = np.broadcast_to(np.asarray(footholds, float), feet.shape)
            slip[stance] = np.linalg.norm(feet[stance] - footholds[stance], axis=1)
            anchors = np.where(stance[..., None] & np.isfinite(footholds), footholds, feet)
        com_margin = self._com_margins(com, anchors, stance)
        clearance, which = self._clearance(centres, stance)
        joints = Q[:, self._joint_q]
        excess = np.maximum(np.maximum(joints - self._upper, self._lower - joints), 0.0)
        return ConfigChecks(foot_positions=feet, foot_gap=gap, foot_slip=slip, com=com,
                            com_margin=com_margin, clearance=clearance, clearance_sphere=which,
                            joint_excess=excess.reshape(n, -1), sphere_centres=centres)

    @staticmethod
    def _com_margins(com, anchors, stance) -> np.ndarray:
        """Signed distance of each CoM to its support polygon. The configurations are grouped by
        their stance anchors (rounded to 1e-9 m): one polygon per group, built from the group's first
        configuration, and the distances of the whole group at once."""
        out = np.full(len(com), -np.inf)
        for pattern in np.unique(stance, axis=0):
            rows = np.flatnonzero((stance == pattern).all(axis=1))
            pts = anchors[rows][:, pattern, :2].reshape(len(rows), -1)
            keys = np.ascontiguousarray(np.round(pts, 9))  # the rounded bytes decide, as a dict key would
            keys = keys.view(np.dtype((np.void, keys.dtype.itemsize * keys.shape[1]))).ravel()
            _, first, group = np.unique(keys, return_index=True, return_inverse=True)
            for g, row in enumerate(rows[first]):
                try:
                    poly = support_polygon(anchors[row, pattern, :2])
                except ValueError:
                    continue
                members = rows[group.ravel() == g]
                out[members] = poly.signed_distance(com[members, :2])
        return out

    def _clearance(self, centres, stance):
        """Smallest sphere clearance per configuration with few FCL calls (bounds first).

        A sphere whose lower bound exceeds the best upper bound of its configuration cannot be the
        closest one, so exact FCL distances are needed only for the remaining candidates.
        """
        n, s = centres.shape[:2]
        exempt = np.zeros((n, s), bool)
        on_leg = self._sphere_leg >= 0
        exempt[:, on_leg] = stance[:, self._sphere_leg[on_leg]] & self._sphere_is_foot[on_leg]
        flat = centres.reshape(-1, 3)
        lb, ub, exact = self.surface.distance_bounds(flat)
        lb = lb.reshape(n, s) - self._radii
        ub = ub.reshape(n, s) - self._radii
        exact = exact.reshape(n, s)
        lb[exempt] = np.inf
        ub[exempt] = np.inf
        best_ub = ub.min(axis=1, initial=np.inf)
        todo = ~exempt & ~exact & (lb < best_ub[:, None])
        value = lb.copy()
        if todo.any():
            rows, cols = np.nonzero(todo)
            value[rows, cols] = self.surface.fcl_distance(centres[rows, cols]) - self._radii[cols]
        which = np.argmin(value, axis=1) if s else np.zeros(n, int)
        clearance = value[np.arange(n), which] if s else np.full(n, np.inf)
        return clearance, which


def _actuated_q_indices(model, joint_names) -> np.ndarray:
    """Configuration-vector index of each named one-DoF joint of a pinocchio model."""
    indices = []
    for name in joint_names:
        joint_id = model.getJointId(name)
        if joint_id >= model.njoints:
            raise ValueError(f"joint {name!r} is not in the pinocchio model")
        indices.append(model.idx_qs[joint_id])
    return np.asarray(indices, int)
