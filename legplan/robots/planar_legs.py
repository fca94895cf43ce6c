"""Closed-form leg kinematics for the centroidal planner: where a leg's thigh and shank are, given its foot.

The centroidal model (`legplan.dyn`) plans the base and the feet, not the joints; to keep the legs
themselves off the terrain it needs the leg's collision spheres as a function of the foot's
position in the base frame. For the common three-joint leg — hip abduction (HAA) about the base x
axis, then hip and knee flexion (HFE, KFE) about the leg's own y axis — that function is closed
form (the leg's inverse kinematics, knee on the side it has in the nominal stance):

* HAA: after the abduction α, the knee and the foot lie in the plane y' = w of the abducted frame
  (w their lateral offset from the HAA axis), so with T the foot relative to the HAA joint,
  T_y² + T_z² = w² + z'², z' = −√(T_y² + T_z² − w²) the foot's depth in that plane, and
  (cos α, sin α) = (w T_y + z' T_z, w T_z − z' T_y) / (T_y² + T_z²).
* HFE, KFE: in the plane, the hip H = (h_x, h_z), the foot F = (T_x, z'), the thigh's in-plane
  length l₁ and the shank l₂ give the knee K = H + a u + σ b n with d = |F − H|, u = (F − H)/d,
  n ⟂ u, a = (l₁² − l₂² + d²)/(2d), b = √(l₁² − a²) (0 where the foot is out of reach), σ the
  nominal knee side.
* A sphere on the thigh (shank) turns with it about y: its offset from the hip (knee) in the nominal
  stance, rotated in the x-z plane by the angle from the nominal thigh (shank) direction to the
  current one, then everything by α about x.
* The joint angles (`joints`): HAA s₀ α (s_j = ±1 the sign of joint j's axis along x or y); a turn
  θ about +y takes an in-plane direction's angle φ (from x towards z) to φ − θ, so with Δφ₁ (Δφ₂)
  the angle from the nominal thigh (shank) direction to the current one, HFE q₁⁰ − s₁ Δφ₁ and KFE
  q₂⁰ − s₂ (Δφ₂ − Δφ₁) (q⁰ the nominal joints, the second wrapped to (−π, π]). This is the
  inverse kinematics with the knee on the nominal side and the foot below the HAA axis, the
  solution `legplan.dyn.legs.ChainLegs` keeps; it is NaN where the foot is out of reach (b² at or
  below `REACH_FLOOR`, or the foot within w of the HAA axis), where the chain's least-squares
  answer applies.

Only +, ·, / and √ appear, so the function takes complex arguments (a complex step differentiates
it exactly); `sphere_centres_and_jacobian` gives the centres with their derivative in closed form,
the chain rule through the steps above, which the planner uses. The geometry is read from the robot's URDF at the nominal stance (HAA at 0);
`PlanarLegs.of_robot` returns None for a robot whose legs are not of this kind.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

AXIS_TOLERANCE = 1e-6  # |axis × expected axis| and in-plane offsets that count as exact (m, rad)
REACH_FLOOR = 1e-9  # m²: b² below this (the foot at or beyond full reach) is taken as this


@dataclass(frozen=True)
class PlanarLegs:
    """Per leg (the robot's leg order; arrays (n_legs, ...)): the HAA joint `haa` (3,) in the base
    frame, the hip `hip` (x, y, z) relative to it, the lateral offset `lateral` w of knee and foot,
    the in-plane thigh `thigh` l₁ and `shank` l₂, the knee side `knee_side` σ, and the nominal
    in-plane thigh and shank directions (x, z). Per collision sphere of a leg (not its foot):
    `sphere_leg`, `sphere_link` (0 thigh, 1 shank), `sphere_offset` from the hip or knee in the
    nominal stance (3,), `sphere_radius`, `sphere_index` into the robot's sphere set. Per leg and
    joint (HAA, HFE, KFE) the sign `axis_sign` of its axis along x, y, y and the angle `reference`
    the geometry was read at (HAA 0, HFE and KFE nominal)."""

    haa: np.ndarray
    hip: np.ndarray
    lateral: np.ndarray
    thigh: np.ndarray
    shank: np.ndarray
    knee_side: np.ndarray
    thigh_direction: np.ndarray
    shank_direction: np.ndarray
    sphere_leg: np.ndarray
    sphere_link: np.ndarray
    sphere_offset: np.ndarray
    sphere_radius: np.ndarray
    sphere_index: np.ndarray
    axis_sign: np.ndarray
    reference: np.ndarray

    @classmethod
    def of_robot(cls, robot, spheres: bool = True) -> PlanarLegs | None:
        """The closed-form legs of a `RobotModel` (module docstring); None unless every leg is an
        HAA-x, HFE-y, KFE-y chain with knee and foot in one plane and, with `spheres`, every leg
        sphere but the foot on the thigh or shank (without: the joints alone, no spheres read)."""
        model, data = robot.model, robot.model.createData()
        q = robot.q_nominal.copy()
        q[:7] = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]
        joints = [[model.getJointId(name) for name in leg.joint_names] for leg in robot.legs]
        if any(len(j) != 3 for j in joints):
            return None
        for haa, _, _ in joints:
            q[model.idx_qs[haa]] = 0.0
        pin.forwardKinematics(model, data, q)
        pin.updateFramePlacements(model, data)
        rows = {name: [] for name in ("haa", "hip", "lateral", "thigh", "shank", "knee_side", "thigh_direction",
                                      "shank_direction", "axis_sign", "reference")}
        picked = {name: [] for name in ("leg", "link", "offset", "radius", "index")}
        scratch = model.createData()  # the turned configurations' FK, one workspace for every joint
        for k, (leg, (haa, hfe, kfe)) in enumerate(zip(robot.legs, joints)):
            axes = [_joint_axis(model, data, q, j, scratch) for j in (haa, hfe, kfe)]
            if not all(np.linalg.norm(np.cross(a, e)) < AXIS_TOLERANCE
                       for a, e in zip(axes, ([1.0, 0, 0], [0, 1.0, 0], [0, 1.0, 0]))):
                return None
            origin = data.oMi[haa].translation.copy()
            hip, knee = data.oMi[hfe].translation - origin, data.oMi[kfe].translation - origin
            foot = data.oMf[leg.foot_frame_id].translation - origin
            if abs(knee[1] - foot[1]) > AXIS_TOLERANCE or foot[2] >= 0.0:
                return None
            lateral = knee[1]
            thigh = np.linalg.norm(knee - hip) ** 2 - (lateral - hip[1]) ** 2
            shank = np.hypot(foot[0] - knee[0], foot[2] - knee[2])
            h2, k2, f2 = hip[[0, 2]], knee[[0, 2]], foot[[0, 2]]
            u = (f2 - h2) / np.linalg.norm(f2 - h2)
            side = np.sign((k2 - h2) @ np.array([-u[1], u[0]]))
            rows["haa"].append(origin)
            rows["hip"].append(hip)
            rows["lateral"].append(lateral)
            rows["thigh"].append(np.sqrt(thigh))
            rows["shank"].append(shank)
            rows["knee_side"].append(side)
            rows["thigh_direction"].append((k2 - h2) / np.sqrt(thigh))
            rows["shank_direction"].append((f2 - k2) / shank)
            rows["axis_sign"].append(np.sign([axes[0][0], axes[1][1], axes[2][1]]))
            rows["reference"].append([q[model.idx_qs[j]] for j in (haa, hfe, kfe)])
            on_leg = (np.asarray(robot.spheres.leg_index) == k) & ~np.asarray(robot.spheres.is_foot)
            for s in np.flatnonzero(on_leg) if spheres else ():
                frame = model.frames[int(robot.spheres.frame_ids[s])]
                parent = frame.parentJoint
                if parent not in (hfe, kfe):
                    return None
                centre = data.oMf[int(robot.spheres.frame_ids[s])].act(robot.spheres.offsets[s]) - origin
                picked["leg"].append(k)
                picked["link"].append(0 if parent == hfe else 1)
                picked["offset"].append(centre - (hip if parent == hfe else knee))
                picked["radius"].append(robot.spheres.radii[s])
                picked["index"].append(s)
        return cls(**{name: np.array(value, float) for name, value in rows.items()},
                   sphere_leg=np.array(picked["leg"], int), sphere_link=np.array(picked["link"], int),
                   sphere_offset=np.array(picked["offset"], float).reshape(-1, 3),
                   sphere_radius=np.array(picked["radius"], float), sphere_index=np.array(picked["index"], int))

    def spheres_of(self, leg: int) -> np.ndarray:
        """Indices (into the `sphere_*` arrays) of the spheres of one leg."""
        return np.flatnonzero(self.sphere_leg == leg)

    def _plane(self, leg, feet: np.ndarray):
        """The leg in its abducted plane (module docstring): the foot t relative to the HAA joint,
        its depth z', (cos α, sin α), the knee (x, z) and b² before its floor; real or complex. `leg`
        one leg, or one per row of `feet` (an int array): the same operations on each row."""
        t = feet - self.haa[leg]
        w = self.lateral[leg]
        rho2 = t[:, 1] ** 2 + t[:, 2] ** 2
        depth = -np.sqrt(rho2 - w ** 2)
        cos_a, sin_a = (w * t[:, 1] + depth * t[:, 2]) / rho2, (w * t[:, 2] - depth * t[:, 1]) / rho2
        hip = self.hip[leg]
        dx, dz = t[:, 0] - hip[..., 0], depth - hip[..., 2]
        d2 = dx ** 2 + dz ** 2
        d = np.sqrt(d2)
        l1, l2 = self.thigh[leg], self.shank[leg]
        a = (l1 ** 2 - l2 ** 2 + d2) / (2.0 * d)
        b2 = l1 ** 2 - a ** 2
        b = np.sqrt(np.where(b2.real > REACH_FLOOR, b2, REACH_FLOOR))
        ux, uz = dx / d, dz / d
        side = self.knee_side[leg]
        return t, depth, cos_a, sin_a, hip[..., 0] + a * ux - side * b * uz, hip[..., 2] + a * uz + side * b * ux, b2

    def joints(self, leg: int, feet: np.ndarray) -> np.ndarray:
        """The joints (n, 3: HAA, HFE, KFE) that put the leg's foot at `feet` (n, 3, base frame), knee
        on its nominal side; NaN rows where the foot is out of reach (module docstring)."""
        with np.errstate(invalid="ignore"):
            t, depth, cos_a, sin_a, knee_x, knee_z, b2 = self._plane(leg, np.asarray(feet, float))
        hip, (l1, l2) = self.hip[leg], (self.thigh[leg], self.shank[leg])
        thigh = _turn(self.thigh_direction[leg], (knee_x - hip[0]) / l1, (knee_z - hip[2]) / l1)
        shank = _turn(self.shank_direction[leg], (t[:, 0] - knee_x) / l2, (depth - knee_z) / l2)
        sign, reference = self.axis_sign[leg], self.reference[leg]
        q = np.stack([reference[0] + sign[0] * np.arctan2(sin_a, cos_a), reference[1] - sign[1] * thigh,
                      reference[2] - sign[2] * (np.mod(shank - thigh + np.pi, 2.0 * np.pi) - np.pi)], axis=1)
        q[~(b2 > REACH_FLOOR)] = np.nan  # NaN b² too: the foot within w of the HAA axis
        return q

    def sphere_centres(self, leg, feet: np.ndarray) -> np.ndarray:
        """Centres (n, k, 3), base frame, of the leg's k spheres with its foot at `feet` (n, 3), base
        frame; real or complex (module docstring). `leg`: one leg, or one per row (an int array;
        every leg with as many spheres, `sphere_slots`)."""
        t, depth, cos_a, sin_a, knee_x, knee_z, _ = self._plane(leg, feet)
        hip, w, l1, l2 = self.hip[leg], self.lateral[leg], self.thigh[leg], self.shank[leg]
        pick = self.sphere_slots()[leg].T if np.ndim(leg) else self.spheres_of(leg)  # per sphere: its index (per row)
        out = []
        for s in pick:
            thigh = self.sphere_link[s] == 0
            start_x = np.where(thigh, hip[..., 0], knee_x)
            start_y = np.where(thigh, hip[..., 1], w)
            start_z = np.where(thigh, hip[..., 2], knee_z)
            now_x = np.where(thigh, (knee_x - hip[..., 0]) / l1, (t[:, 0] - knee_x) / l2)
            now_z = np.where(thigh, (knee_z - hip[..., 2]) / l1, (depth - knee_z) / l2)
            nominal = np.where(np.asarray(thigh)[..., None], self.thigh_direction[leg], self.shank_direction[leg])
            cos_p = nominal[..., 0] * now_x + nominal[..., 1] * now_z
            sin_p = nominal[..., 0] * now_z - nominal[..., 1] * now_x
            offset = self.sphere_offset[s]
            ox, oy, oz = offset[..., 0], offset[..., 1], offset[..., 2]
            x = start_x + cos_p * ox - sin_p * oz
            y = np.broadcast_to(start_y + oy, x.shape)
            z = start_z + sin_p * ox + cos_p * oz
            out.append(np.stack([x, y * cos_a - z * sin_a, y * sin_a + z * cos_a], axis=-1) + self.haa[leg])
        return np.stack(out, axis=1) if len(out) else np.zeros((len(feet), 0, 3), dtype=feet.dtype)

    def sphere_slots(self) -> np.ndarray | None:
        """The spheres of every leg (legs, k) when all legs carry the same number k (for rows of
        several legs at once), else None."""
        per_leg = [self.spheres_of(leg) for leg in range(len(self.haa))]
        return np.array(per_leg) if len({p.size for p in per_leg}) == 1 else None

    def sphere_centres_and_jacobian(self, leg, feet: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """`sphere_centres` (n, k, 3) of real feet (n, 3) with ∂centre/∂foot (n, k, 3, 3) in closed
        form: the chain rule through the module docstring's steps, each differentiated by hand
        (∂z' = (0, T_y, T_z)/z', ∂a = ∂d²/(2d) − a ∂d/d, ∂b = −a ∂a/b, 0 where b² is floored, as
        `sphere_centres`' complex step gives it), all spheres at once. `leg`: one leg, or one per
        row (an int array; every leg with as many spheres, `sphere_slots`)."""
        feet = np.asarray(feet, float)
        n = len(feet)
        if np.ndim(leg):
            legs, pick = np.asarray(leg), self.sphere_slots()[leg]  # (n,), (n, k)
        else:
            legs, pick = np.full(n, leg), np.broadcast_to(self.spheres_of(leg), (n, self.spheres_of(leg).size))
        if not pick.shape[1]:
            return np.zeros((n, 0, 3)), np.zeros((n, 0, 3, 3))
        t, depth, cos_a, sin_a, knee_x, knee_z, b2 = self._plane(legs, feet)
        hip, w, l1, l2, side = self.hip[legs], self.lateral[legs], self.thigh[legs], self.shank[legs], self.knee_side[legs]
        col = lambda x: x[:, None]  # a per-row quantity against (n, 3) or (n, k) arrays
        zero, one = np.zeros(n), np.ones(n)
        # derivatives w.r.t. the foot (x, y, z), each (n, 3)
        rho2 = t[:, 1] ** 2 + t[:, 2] ** 2
        d_depth = np.stack([zero, t[:, 1] / depth, t[:, 2] / depth], axis=1)
        d_rho2 = np.stack([zero, 2.0 * t[:, 1], 2.0 * t[:, 2]], axis=1)
        d_cos = (col(t[:, 2]) * d_depth - col(cos_a) * d_rho2) / col(rho2)
        d_cos[:, 1] += w / rho2
        d_cos[:, 2] += depth / rho2
        d_sin = (-col(t[:, 1]) * d_depth - col(sin_a) * d_rho2) / col(rho2)
        d_sin[:, 1] -= depth / rho2
        d_sin[:, 2] += w / rho2
        dx, dz = t[:, 0] - hip[:, 0], depth - hip[:, 2]
        d = np.sqrt(dx ** 2 + dz ** 2)
        ux, uz = dx / d, dz / d
        a = (l1 ** 2 - l2 ** 2 + d ** 2) / (2.0 * d)
        b = np.sqrt(np.where(b2 > REACH_FLOOR, b2, REACH_FLOOR))
        d_dx = np.stack([one, zero, zero], axis=1)
        d_d = col(ux) * d_dx + col(uz) * d_depth
        d_a = d_d - col(a / d) * d_d  # ∂d²/(2d) = ∂d
        d_b = np.where(col(b2 > REACH_FLOOR), -col(a / b) * d_a, 0.0)
        d_ux = (d_dx - col(ux) * d_d) / col(d)
        d_uz = (d_depth - col(uz) * d_d) / col(d)
        d_kx = d_a * col(ux) + col(a) * d_ux - col(side) * (d_b * col(uz) + col(b) * d_uz)
        d_kz = d_a * col(uz) + col(a) * d_uz + col(side) * (d_b * col(ux) + col(b) * d_ux)
        thigh = self.sphere_link[pick] == 0  # (n, k)
        # per sphere (n, k): the link's start, its direction now (and their derivatives (n, k, 3))
        start_x = np.where(thigh, col(hip[:, 0]), col(knee_x))
        start_y = np.where(thigh, col(hip[:, 1]), col(w))
        start_z = np.where(thigh, col(hip[:, 2]), col(knee_z))
        d_start_x = np.where(thigh[..., None], 0.0, d_kx[:, None])
        d_start_z = np.where(thigh[..., None], 0.0, d_kz[:, None])
        now_x = np.where(thigh, col((knee_x - hip[:, 0]) / l1), col((t[:, 0] - knee_x) / l2))
        now_z = np.where(thigh, col((knee_z - hip[:, 2]) / l1), col((depth - knee_z) / l2))
        d_now_x = np.where(thigh[..., None], (d_kx / col(l1))[:, None], ((d_dx - d_kx) / col(l2))[:, None])
        d_now_z = np.where(thigh[..., None], (d_kz / col(l1))[:, None], ((d_depth - d_kz) / col(l2))[:, None])
        nominal = np.where(thigh[..., None], self.thigh_direction[legs][:, None], self.shank_direction[legs][:, None])
        n0, n1 = nominal[..., 0], nominal[..., 1]  # (n, k)
        cos_p, sin_p = n0 * now_x + n1 * now_z, n0 * now_z - n1 * now_x
        d_cos_p = n0[..., None] * d_now_x + n1[..., None] * d_now_z
        d_sin_p = n0[..., None] * d_now_z - n1[..., None] * d_now_x
        offset = self.sphere_offset[pick]  # (n, k, 3)
        ox, oy, oz = offset[..., 0], offset[..., 1], offset[..., 2]
        x = start_x + cos_p * ox - sin_p * oz
        y = start_y + oy
        z = start_z + sin_p * ox + cos_p * oz
        d_x = d_start_x + d_cos_p * ox[..., None] - d_sin_p * oz[..., None]
        d_z = d_start_z + d_sin_p * ox[..., None] + d_cos_p * oz[..., None]
        c, s = col(cos_a), col(sin_a)
        centres = np.empty((n, pick.shape[1], 3))
        centres[..., 0] = x
        centres[..., 1] = y * c - z * s
        centres[..., 2] = y * s + z * c
        centres += self.haa[legs][:, None]
        jac = np.empty((n, pick.shape[1], 3, 3))
        jac[:, :, 0] = d_x
        jac[:, :, 1] = y[..., None] * d_cos[:, None] - d_z * s[..., None] - z[..., None] * d_sin[:, None]
        jac[:, :, 2] = y[..., None] * d_sin[:, None] + d_z * c[..., None] + z[..., None] * d_cos[:, None]
        return centres, jac


def _turn(nominal, x, z):
    """The angle (from x towards z) from the unit direction `nominal` (x, z) to the unit (x, z)."""
    return np.arctan2(nominal[0] * z - nominal[1] * x, nominal[0] * x + nominal[1] * z)


def _joint_axis(model: pin.Model, data: pin.Data, q: np.ndarray, joint: int, other: pin.Data) -> np.ndarray:
    """The rotation axis of a one-degree-of-freedom joint in the base frame at q (from the change of
    its placement under a small turn; `data` holds the FK at q, `other` is a workspace for the turn)."""
    turned = q.copy()
    turned[model.idx_qs[joint]] += 1e-6
    rotation = data.oMi[joint].rotation.copy()
    pin.forwardKinematics(model, other, turned)
    axis = rotation @ pin.log3(rotation.T @ other.oMi[joint].rotation)
    return axis / np.linalg.norm(axis)
