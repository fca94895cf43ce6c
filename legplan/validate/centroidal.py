"""Independent check of a centroidal trajectory (issue 14, "Independent check of every solution").

The solution of `legplan dyn plan`, sampled every 10 ms (`t`, base pose and rates, feet, forces,
contact flags), is checked against the model it claims to obey with code that did not produce it:
nothing from `legplan.dyn` is used. The rotation R = Rz(yaw) Ry(pitch) Rx(roll) comes from pinocchio,
the terrain from the map's own layers (`TerrainMap.height_at`, bilinear between cell centres, and
the 3D SDF `TerrainMap.surface_distance`), leg kinematics from pinocchio (`legplan.robots`).

Metrics (the worst value over all samples; units in `UNITS`; "pass" ones are judged by `CheckTolerances`):

  newton_euler_force        recorded  max over samples of |m(p̈ + g e_z) − Σ f_i|∞ (N), the linear
                                      row of the single-rigid-body dynamics (Winkler et al. 2018, eq. (1))
  newton_euler_torque       recorded  max |I_W ω̇ + ω × I_W ω − Σ (p_i − p) × f_i|∞ (N·m),
                                      I_W = R I_B Rᵀ (the angular row)
  newton_euler_force_nodes  pass      the same at the node times, where the formulation enforces the
  newton_euler_torque_nodes pass      dynamics: ≤ rel·m·g and ≤ rel·m·g·ℓ (ℓ: the largest horizontal
                                      distance of a nominal foot from the CoM, i.e. a foot-force error
                                      of rel·m·g). Between nodes the rows are not constrained, so the
                                      all-sample values are recorded only.
  angular_velocity          pass      |ω − ω(e, ė)| (rad/s): the sampled world ω against the one of
                                      the sampled Euler angles and rates, ω = ψ̇ e_z + θ̇ Rz e_y + φ̇ Rz Ry e_x
  normal_force              pass      violation of 0 ≤ f·n ≤ f_max, relative (see below), stance feet
  friction_pyramid          pass      max(|f·t1|, |f·t2|) − μ f·n, relative, with TOWR's terrain basis
                                      n ∝ (−h_x, −h_y, 1), t1 ∝ (1, 0, h_x), t2 ∝ (0, 1, h_y)
  friction_cone             recorded  |f − (f·n) n| − μ f·n, relative (the pyramid admits up to √2 μ)
  swing_force               pass      |f| of feet whose contact flag is false, relative
  stance_slip               pass      largest distance of a stance foot from where its contact phase
                                      began (m)
  stance_height             pass      |z − h(x, y)| of stance feet (m), h the bilinear heightmap
  stance_sdf                recorded  |SDF| of stance feet (m): the SDF is that of the column solid,
                                      which on slopes stands up to half a cell proud of h
  penetration_height        pass      max(h(x, y) − z, 0) of any foot (m)
  penetration_sdf           pass      max(−SDF, 0) of any foot (m), tolerance + half a cell (column model)
  base_height               recorded  min of base z − h(base x, y) (m)
  base_above_feet           recorded  min of base z − the highest foot z (m)
  trunk_penetration         pass      max over the trunk's collision spheres of radius − SDF(centre) (m):
                                      how deep the trunk reaches into the terrain (< 0: clear by that much)
  range_of_motion           pass      max(|Rᵀ(p_i − p) − p̄_i| − r, 0) over axes (m), the box of TOWR's
                                      kinematic model
  leg_reach                 pass      largest foot error (m) of per-foot IK inside the URDF's planning
                                      joint limits (`legplan.robots.leg_reach`)
  joint_limit_margin        recorded  smallest distance of an IK solution's joint to its limit (rad)
  leg_penetration           recorded  max over the legs' thigh and shank collision spheres, at the IK
                                      solution, of radius − SDF(centre) (m); judged (pass) with
                                      `CheckTolerances.legs`, for a plan made with leg clearance

"Relative" force violations are divided by max(f·n, m g / 4) (the force of one foot of four
carrying the weight), so 1e-3 means a thousandth of a foot's share of the weight or of the force.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from legplan.robots import leg_reach

GRAVITY = 9.81
HEIGHT_STEP = 1e-6  # m, central-difference step of the heightmap gradient

UNITS = {"newton_euler_force": "N", "newton_euler_torque": "N m", "newton_euler_force_nodes": "N",
         "newton_euler_torque_nodes": "N m", "angular_velocity": "rad/s", "normal_force": "1",
         "friction_pyramid": "1", "friction_cone": "1", "swing_force": "1", "stance_slip": "m",
         "stance_height": "m", "stance_sdf": "m", "penetration_height": "m", "penetration_sdf": "m",
         "base_height": "m", "base_above_feet": "m", "trunk_penetration": "m", "range_of_motion": "m",
         "leg_reach": "m", "joint_limit_margin": "rad", "leg_penetration": "m"}


@dataclass(frozen=True)
class CheckTolerances:
    """Pass/fail bounds. `newton_euler` and `force` are relative (see the module docstring);
    `penetration` is the issue's "no foot more than 5 mm below the terrain"; `leg_reach` is the IK
    tolerance; `node_dt` (s) the largest node spacing of the dynamics (TOWR's and `legplan dyn`'s
    0.1 s), used when the node times are not given."""

    newton_euler: float = 1e-3
    angular_velocity: float = 1e-6
    force: float = 1e-3
    slip: float = 1e-3
    stance_height: float = 1e-3
    penetration: float = 5e-3
    range_of_motion: float = 1e-3
    leg_reach: float = 1e-4
    node_dt: float = 0.1
    legs: bool = False
    """Judge `leg_penetration` by `penetration` (a plan that claims its legs clear of the terrain:
    `DynParams.leg_clearance`); otherwise it is recorded."""


@dataclass
class CentroidalCheck:
    """Worst value of every metric (`UNITS`), and for the pass/fail ones the tolerance used and
    whether it passed."""

    worst: dict[str, float]
    tolerance: dict[str, float]
    passed: dict[str, bool]
    units: dict[str, str] = field(default_factory=lambda: dict(UNITS))

    @property
    def ok(self) -> bool:
        """Every pass/fail metric passed."""
        return all(self.passed.values())

    def as_dict(self) -> dict[str, float | bool]:
        """Flat scalars for HDF5 attributes: `<metric>` (worst), `<metric>_tolerance` and
        `<metric>_passed` for the judged ones, and `passed` overall."""
        out: dict[str, float | bool] = {}
        for name, value in self.worst.items():
            out[name] = float(value)
            if name in self.passed:
                out[f"{name}_tolerance"] = float(self.tolerance[name])
                out[f"{name}_passed"] = bool(self.passed[name])
        out["passed"] = self.ok
        return out


def check_trajectory(samples: dict, model, terrain_map, robot, tolerances: CheckTolerances = CheckTolerances(),
                     node_times=None) -> CentroidalCheck:
    """Check the sampled trajectory `samples` (keys of `legplan.dyn.planner.sample_solution`, legs in
    `model.legs` order) of the centroidal `model` on `terrain_map` (a `TerrainMap`), with `robot`'s
    legs for reachability. `node_times` (s) are where the dynamics are enforced (default: the evenly
    spaced knots at most `tolerances.node_dt` apart over [0, T]); those that fall on no sample are
    skipped. See the module docstring for the metrics."""
    s = {k: np.asarray(v) for k, v in samples.items()}
    t, p, contact = s["t"].astype(float), s["base_pos"].astype(float), s["contact"].astype(bool)
    feet, forces = s["feet_pos"].astype(float), s["forces"].astype(float)
    rot = np.array([pin.rpy.rpyToMatrix(e) for e in s["base_euler"].astype(float)]).reshape(-1, 3, 3)  # Rz Ry Rx
    weight = model.mass * GRAVITY
    lever = float(np.linalg.norm(model.nominal_feet[:, :2], axis=1).max())
    rel = tolerances.newton_euler

    force_res, torque_res = _newton_euler(model, p, s["base_acc"], rot, s["base_ang_vel"], s["base_ang_acc"],
                                          feet, forces)
    if node_times is None:
        count = max(1, int(np.ceil((t[-1] - t[0]) / tolerances.node_dt - 1e-9)))
        node_times = np.linspace(t[0], t[-1], count + 1)
    nodes = _node_samples(t, np.asarray(node_times, float))
    omega = _euler_world_rates(s["base_euler"], s["base_euler_rate"])
    worst = {"newton_euler_force": force_res.max(), "newton_euler_torque": torque_res.max(),
             "newton_euler_force_nodes": force_res[nodes].max(initial=0.0),
             "newton_euler_torque_nodes": torque_res[nodes].max(initial=0.0),
             "angular_velocity": _max(np.linalg.norm(s["base_ang_vel"] - omega, axis=1))}
    worst.update(_forces(model, terrain_map, feet, forces, contact))
    worst.update(_feet_on_terrain(terrain_map, feet, contact))
    worst.update(_base(terrain_map, p, feet))
    offset = np.abs(np.einsum("nji,nlj->nli", rot, feet - p[:, None]) - model.nominal_feet) - model.range_of_motion
    worst["range_of_motion"] = _max(np.maximum(offset, 0.0))
    reach, joints = _reach(robot, model, p, rot, feet, tolerances.leg_reach)
    worst.update(reach)
    worst.update(_spheres(robot, terrain_map, p, rot, joints))

    half_cell = 0.5 * float(terrain_map.grid.resolution)
    tolerance = {"newton_euler_force_nodes": rel * weight, "newton_euler_torque_nodes": rel * weight * lever,
                 "angular_velocity": tolerances.angular_velocity, "normal_force": tolerances.force,
                 "friction_pyramid": tolerances.force, "swing_force": tolerances.force,
                 "stance_slip": tolerances.slip, "stance_height": tolerances.stance_height,
                 "penetration_height": tolerances.penetration,
                 "penetration_sdf": tolerances.penetration + half_cell, "trunk_penetration": tolerances.penetration,
                 "range_of_motion": tolerances.range_of_motion, "leg_reach": tolerances.leg_reach}
    if tolerances.legs:
        tolerance["leg_penetration"] = tolerances.penetration
    worst = {name: float(worst[name]) for name in UNITS}
    passed = {name: bool(worst[name] <= bound) for name, bound in tolerance.items()}
    return CentroidalCheck(worst=worst, tolerance=tolerance, passed=passed)


def _max(values) -> float:
    """Largest entry, 0 for an empty array."""
    return float(np.max(values, initial=0.0))


def _node_samples(t: np.ndarray, node_times: np.ndarray) -> np.ndarray:
    """Indices of the samples at the node times (within 1 µs)."""
    k = np.clip(np.searchsorted(t, node_times), 1, len(t) - 1)
    nearest = np.where(np.abs(t[k - 1] - node_times) <= np.abs(t[k] - node_times), k - 1, k)
    return np.unique(nearest[np.abs(t[nearest] - node_times) <= 1e-6])


def _euler_world_rates(euler: np.ndarray, rates: np.ndarray) -> np.ndarray:
    """World angular velocity (n, 3) of R = Rz(ψ) Ry(θ) Rx(φ) for Euler rates (φ̇, θ̇, ψ̇):
    ω = ψ̇ e_z + θ̇ Rz(ψ) e_y + φ̇ Rz(ψ) Ry(θ) e_x (each rate about its axis as currently rotated)."""
    _, pitch, yaw = euler.T
    cy, sy, cp, sp = np.cos(yaw), np.sin(yaw), np.cos(pitch), np.sin(pitch)
    zero = np.zeros_like(yaw)
    ez = np.stack([zero, zero, np.ones_like(yaw)], axis=1)
    ey = np.stack([-sy, cy, zero], axis=1)
    ex = np.stack([cy * cp, sy * cp, -sp], axis=1)
    return rates[:, 2:3] * ez + rates[:, 1:2] * ey + rates[:, 0:1] * ex


def _newton_euler(model, p, acc, rot, omega, omega_dot, feet, forces):
    """Largest component (n,) of the force residual m(p̈ + g e_z) − Σ f_i (N) and of the torque
    residual I_W ω̇ + ω × I_W ω − Σ (p_i − p) × f_i (N·m) about the CoM, I_W = R I_B Rᵀ."""
    linear = model.mass * (acc + [0.0, 0.0, GRAVITY]) - forces.sum(axis=1)
    inertia = rot @ model.inertia @ np.swapaxes(rot, 1, 2)
    angular = (np.einsum("nij,nj->ni", inertia, omega_dot)
               + np.cross(omega, np.einsum("nij,nj->ni", inertia, omega))
               - np.cross(feet - p[:, None], forces).sum(axis=1))
    return np.abs(linear).max(axis=1), np.abs(angular).max(axis=1)


def _terrain_basis(terrain_map, xy: np.ndarray):
    """Unit normal n and tangents t1, t2 (each (..., 3)) of the bilinear heightmap at xy (..., 2),
    TOWR's basis n ∝ (−h_x, −h_y, 1), t1 ∝ (1, 0, h_x), t2 ∝ (0, 1, h_y), the gradient by central
    differences of `height_at`."""
    flat = xy.reshape(-1, 2)
    dx, dy = np.array([HEIGHT_STEP, 0.0]), np.array([0.0, HEIGHT_STEP])
    hx = (terrain_map.height_at(flat + dx) - terrain_map.height_at(flat - dx)) / (2 * HEIGHT_STEP)
    hy = (terrain_map.height_at(flat + dy) - terrain_map.height_at(flat - dy)) / (2 * HEIGHT_STEP)
    one, zero = np.ones_like(hx), np.zeros_like(hx)
    unit = lambda a: (a / np.linalg.norm(a, axis=1, keepdims=True)).reshape(xy.shape[:-1] + (3,))
    return (unit(np.stack([-hx, -hy, one], axis=1)), unit(np.stack([one, zero, hx], axis=1)),
            unit(np.stack([zero, one, hy], axis=1)))


def _forces(model, terrain_map, feet, forces, contact) -> dict[str, float]:
    """Force bounds, friction pyramid and cone of stance feet, and swing-foot forces, relative to
    max(f·n, m g / 4)."""
    share = model.mass * GRAVITY / 4.0
    n, t1, t2 = _terrain_basis(terrain_map, feet[..., :2])
    fn = np.sum(forces * n, axis=-1)
    scale = np.maximum(fn, share)
    tangential = forces - fn[..., None] * n
    mu = model.friction
    pyramid = np.maximum(np.abs(np.sum(forces * t1, axis=-1)), np.abs(np.sum(forces * t2, axis=-1))) - mu * fn
    bounds = np.maximum(-fn, fn - model.max_normal_force)
    cone = np.linalg.norm(tangential, axis=-1) - mu * fn
    return {"normal_force": _max(np.maximum(bounds[contact], 0.0) / scale[contact]),
            "friction_pyramid": _max(np.maximum(pyramid[contact], 0.0) / scale[contact]),
            "friction_cone": _max(np.maximum(cone[contact], 0.0) / scale[contact]),
            "swing_force": _max(np.linalg.norm(forces[~contact], axis=-1) / share)}


def _feet_on_terrain(terrain_map, feet, contact) -> dict[str, float]:
    """Stance slip, stance feet on the terrain, and any foot's depth below it (height field and SDF)."""
    n, legs = contact.shape
    index = np.arange(n)[:, None]
    began = contact & ~np.vstack([np.zeros((1, legs), bool), contact[:-1]])
    first = np.maximum.accumulate(np.where(began, index, 0), axis=0)   # sample where the phase began
    slip = np.linalg.norm(feet - feet[first, np.arange(legs)], axis=-1)
    points = feet.reshape(-1, 3)
    gap = (points[:, 2] - terrain_map.height_at(points[:, :2])).reshape(n, legs)
    sdf = terrain_map.surface_distance(points).reshape(n, legs)
    return {"stance_slip": _max(slip[contact]), "stance_height": _max(np.abs(gap[contact])),
            "stance_sdf": _max(np.abs(sdf[contact])), "penetration_height": _max(np.maximum(-gap, 0.0)),
            "penetration_sdf": _max(np.maximum(-sdf, 0.0))}


def _base(terrain_map, p, feet) -> dict[str, float]:
    """Base height above the terrain and the feet."""
    return {"base_height": float(np.min(p[:, 2] - terrain_map.height_at(p[:, :2]))),
            "base_above_feet": float(np.min(p[:, 2] - feet[..., 2].max(axis=1)))}


def _reach(robot, model, p, rot, feet, tolerance: float) -> tuple[dict[str, float], np.ndarray]:
    """Per-foot IK inside the joint limits (feet reordered from `model.legs` to `robot.legs` by
    name); also returns its joints (n, n_joints)."""
    order = [model.legs.index(leg.name) for leg in robot.legs]
    reach = leg_reach(robot, p, rot, feet[:, order], tolerance=tolerance)
    return {"leg_reach": float(reach.error.max()), "joint_limit_margin": float(reach.limit_margin.min())}, reach.joints


def _spheres(robot, terrain_map, p, rot, joints) -> dict[str, float]:
    """How deep the trunk's and the legs' thigh and shank spheres reach into the terrain (radius −
    SDF of the centre), the centres by one pinocchio FK of the base pose and the IK joints."""
    Q = np.empty((len(p), robot.nq))
    Q[:, :3], Q[:, 3:7], Q[:, 7:] = p, [pin.Quaternion(r).coeffs() for r in rot], joints   # (x, y, z, w)
    index, foot = np.asarray(robot.spheres.leg_index), np.asarray(robot.spheres.is_foot, bool)
    picked = np.flatnonzero(~foot)
    centres = robot.sphere_centres(Q)[:, picked]
    depth = robot.spheres.radii[picked] - terrain_map.surface_distance(centres.reshape(-1, 3)).reshape(len(p), -1)
    trunk = index[picked] == -1
    return {"trunk_penetration": float(depth[:, trunk].max(initial=-np.inf)),
            "leg_penetration": float(depth[:, ~trunk].max(initial=-np.inf))}
