"""Independent check of a centroidal trajectory (issue 14, "Independent check of every solution").

The solution of `legplan dyn plan`, sampled every 10 ms (`t`, base pose and rates, feet, forces,
contact flags), is checked against the model it claims to obey with code that did not produce it:
nothing from `legplan.dyn` is used. The rotation R = Rz(yaw) Ry(pitch) Rx(roll) comes from pinocchio,
the terrain from the map's own heightmap (`TerrainMap.height_at`, bilinear between cell centres, and
the exact distance to its column solid, `legplan.terrain.columns.ColumnDistance`), leg kinematics
from pinocchio (`legplan.robots`).

Metrics (the worst value over all samples; units in `UNITS`). Every metric is judged by a bound
of `CheckTolerances`: the largest value ≤ it, or for those in `MINIMA` the smallest ≥ it:

  newton_euler_force        max over the 10 ms samples of |m(p̈ + g e_z) − Σ f_i|∞ (N), the linear
                            row of the single-rigid-body dynamics (Winkler et al. 2018, eq. (1)),
                            ≤ `between` · m·g at every sample: the dynamics where the robot executes
                            the plan, between the points where the formulation enforces them too
  newton_euler_torque       max |I_W ω̇ + ω × I_W ω − Σ (p_i − c) × f_i|∞ (N·m) about the CoM c (at
                            `Centroidal.com_offset` in the base frame), I_W = R I_B Rᵀ (the angular
                            row), ≤ `between` · m·g·ℓ (ℓ: the largest horizontal distance of a nominal
                            foot from the base origin: a foot-force error of that share of m·g)
  newton_euler_force_nodes  the same at the node times, where the formulation enforces the
  newton_euler_torque_nodes dynamics: ≤ `newton_euler`·m·g and ≤ `newton_euler`·m·g·ℓ
  angular_velocity          |ω − ω(e, ė)| (rad/s): the sampled world ω against the one of
                            the sampled Euler angles and rates, ω = ψ̇ e_z + θ̇ Rz e_y + φ̇ Rz Ry e_x
  normal_force              violation of 0 ≤ f·n ≤ f_max, relative (see below), stance feet
  friction_cone             |f − (f·n) n| − μ f·n, relative: the Coulomb cone (the simulator's
                            elliptic cone), with TOWR's terrain normal n ∝ (−h_x, −h_y, 1)
  swing_force               |f| of feet whose contact flag is false, relative
  stance_slip               largest distance of a stance foot from where its contact phase
                            began (m)
  stance_height             |z − h(x, y)| of stance feet (m), h the bilinear heightmap (the surface
                            the planner stands feet on)
  stance_column             |d| of stance feet (m), d the exact distance to the column solid of the
                            heightmap (`legplan.terrain.columns.ColumnDistance`: the true terrain
                            of the map, edges included), ≤ `penetration`
  penetration_height        max(h(x, y) − z, 0) of any foot (m)
  penetration_column        max(−d, 0) of any foot (m): how deep it reaches into the true terrain
  base_height               min of base z − h(base x, y) (m), ≥ 0
  base_above_feet           min of base z − the highest foot z (m), ≥ 0
  trunk_penetration         max over the trunk's collision spheres of radius − d(centre) (m): how
                            deep the trunk reaches into the terrain (< 0: clear by that much, down to
                            −`SPHERE_REACH`, where the distance is no longer resolved)
  range_of_motion           max(|Rᵀ(p_i − p) − p̄_i| − r, 0) over axes (m), the box of TOWR's
                            kinematic model
  leg_reach                 largest foot error (m) of per-foot IK inside the URDF's planning
                            joint limits (`legplan.robots.leg_reach`)
  joint_limit_margin        smallest distance of an IK solution's joint to its limit (rad), ≥ 0
  leg_penetration           max over every leg's collision spheres but the feet, placed by pinocchio
                            FK at the IK solution, of radius − d(centre) (m): the whole-body check
  joint_torque              max over stance feet and their legs' joints of |τ_j| / τ_max,j, τ = Jᵀ f
                            the torques that hold the foot's force f (J the foot's Jacobian by
                            pinocchio at the IK solution, world-aligned; statics of massless legs)
                            against the torque limits the robot has (`legplan.robots.torque_limits`:
                            robot.yaml's `torque_limits`, else the URDF's efforts, the limits the
                            simulator's motors apply), whatever model planned it: ≤ 1 + `torque`, a
                            plan that needs more torque than the robot has fails. A robot whose
                            efforts are placeholders and that names no limits has its ratio to the
                            URDF's efforts recorded with the bound ∞ (joints without a positive
                            effort are left out)
  line_support              the longest phase in which the same one or two feet carry the base
                            (a trot's diagonal pair, a walk's two-foot exchange), in units of
                            τ = √(h/g), h the nominal base height: on a line or a point of support
                            the base is an inverted pendulum whose deviations from the plan grow as
                            e^{t/τ} (the feet can exert no moment about the line through them), and
                            the executing controller corrects them only where the next feet land;
                            ≤ `line_support` (a slow trot whose diagonal stances last this long
                            leaves the executing controller too far off to recover)

"Relative" force violations are divided by max(f·n, m g / 4) (the force of one foot of four
carrying the weight), so 1e-3 means a thousandth of a foot's share of the weight or of the force.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from legplan.geometry.ordered import median, sorted_unique
from legplan.robots import leg_reach, torque_limits
from legplan.terrain.columns import ColumnDistance

GRAVITY = 9.81
HEIGHT_STEP = 1e-6  # m, central-difference step of the heightmap gradient

SPHERE_REACH = 0.05  # m: distances of sphere surfaces are resolved this far out (`ColumnDistance` reach)

UNITS = {"newton_euler_force": "N", "newton_euler_torque": "N m", "newton_euler_force_nodes": "N",
         "newton_euler_torque_nodes": "N m", "angular_velocity": "rad/s", "normal_force": "1",
         "friction_cone": "1", "swing_force": "1", "stance_slip": "m", "stance_height": "m", "stance_column": "m",
         "penetration_height": "m", "penetration_column": "m", "base_height": "m", "base_above_feet": "m",
         "trunk_penetration": "m", "range_of_motion": "m", "leg_reach": "m", "joint_limit_margin": "rad",
         "leg_penetration": "m", "joint_torque": "1", "line_support": "√(h/g)"}
MINIMA = ("base_height", "base_above_feet", "joint_limit_margin")
"""Metrics whose worst value is the smallest, judged by a lower bound; the rest by an upper one."""


@dataclass(frozen=True)
class CheckTolerances:
    """Pass/fail bounds. `newton_euler`, `between` and `force` are relative (see the module
    docstring); `penetration` is the issue's "no foot more than 5 mm below the terrain", also the
    bound of the trunk's and the legs' spheres; `leg_reach` is the IK tolerance; `node_dt` (s) the
    largest node spacing of the dynamics (TOWR's and `legplan dyn`'s 0.1 s), used when the node
    times are not given."""

    newton_euler: float = 1e-3
    between: float = 0.05
    """Newton–Euler residual at every sample, a share of m·g."""
    angular_velocity: float = 1e-6
    force: float = 1e-3
    slip: float = 1e-3
    stance_height: float = 1e-3
    penetration: float = 5e-3
    range_of_motion: float = 1e-3
    leg_reach: float = 1e-4
    torque: float = 1e-3
    """Relative: joint torques up to (1 + this) × the robot's torque limits."""
    line_support: float = 1.7
    """The longest phase on the same one or two feet, × √(h/g) (module docstring): a deviation
    grows e^1.7 ≈ 5.5-fold in it. Between the longest line support of a trot that executed and the
    shortest of one that fell (BENCHMARKS.md, exec: slow trots)."""
    node_dt: float = 0.1


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

    def failures(self) -> list[str]:
        """'metric worst > tolerance unit' for every judged metric that failed, in `UNITS` order (no
        unit for the dimensionless ratios)."""
        return [f"{name} {self.worst[name]:.4g} {'<' if name in MINIMA else '>'} {self.tolerance[name]:.4g} "
                f"{'' if self.units.get(name) == '1' else self.units.get(name, '')}".rstrip()
                for name in self.worst if name in self.passed and not self.passed[name]]

    def as_dict(self) -> dict[str, float | bool]:
        """Flat scalars for HDF5 attributes: `<metric>` (worst), `<metric>_tolerance` and
        `<metric>_passed` for the judged ones (every one), and `passed` overall."""
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
    offset = np.asarray(model.com_offset, float)
    lever = float(np.linalg.norm((model.nominal_feet - offset)[:, :2], axis=1).max())
    rel = tolerances.newton_euler

    force_res, torque_res = _newton_euler(model, p, s["base_acc"], rot, s["base_ang_vel"], s["base_ang_acc"],
                                          feet, forces)
    if node_times is None:
        count = max(1, int(np.ceil((t[-1] - t[0]) / tolerances.node_dt - 1e-9)))
        node_times = np.linspace(t[0], t[-1], count + 1)
    nodes = _node_samples(t, np.asarray(node_times, float))
    omega = _euler_world_rates(s["base_euler"], s["base_euler_rate"])
    worst = {"newton_euler_force": _max(force_res), "newton_euler_torque": _max(torque_res),
             "newton_euler_force_nodes": force_res[nodes].max(initial=0.0),
             "newton_euler_torque_nodes": torque_res[nodes].max(initial=0.0),
             "angular_velocity": _max(np.linalg.norm(s["base_ang_vel"] - omega, axis=1))}
    worst.update(_forces(model, terrain_map, feet, forces, contact))
    columns = _Columns(terrain_map)
    worst.update(_feet_on_terrain(terrain_map, columns, feet, contact))
    worst.update(_base(terrain_map, p, feet))
    offset = np.abs(np.einsum("nji,nlj->nli", rot, feet - p[:, None]) - model.nominal_feet) - model.range_of_motion
    worst["range_of_motion"] = _max(np.maximum(offset, 0.0))
    reach, joints = _reach(robot, model, p, rot, feet, tolerances.leg_reach)
    worst.update(reach)
    kinematics = _kinematics(robot, p, rot, joints)
    worst.update(_spheres(robot, columns, kinematics.sphere_centres))
    limits = torque_limits(robot)
    worst["joint_torque"] = _joint_torque(robot, model, limits, kinematics.foot_jacobians, forces, contact)
    worst["line_support"] = _line_support(t, contact) / np.sqrt(_base_height(model, robot) / GRAVITY)

    between = tolerances.between
    tolerance = {"newton_euler_force": between * weight, "newton_euler_torque": between * weight * lever,
                 "newton_euler_force_nodes": rel * weight, "newton_euler_torque_nodes": rel * weight * lever,
                 "angular_velocity": tolerances.angular_velocity, "normal_force": tolerances.force,
                 "friction_cone": tolerances.force, "swing_force": tolerances.force,
                 "stance_slip": tolerances.slip, "stance_height": tolerances.stance_height,
                 "stance_column": tolerances.penetration, "penetration_height": tolerances.penetration,
                 "penetration_column": tolerances.penetration, "base_height": 0.0, "base_above_feet": 0.0,
                 "trunk_penetration": tolerances.penetration, "range_of_motion": tolerances.range_of_motion,
                 "leg_reach": tolerances.leg_reach, "joint_limit_margin": 0.0,
                 "leg_penetration": tolerances.penetration,
                 "joint_torque": np.inf if limits is None else 1.0 + tolerances.torque,
                 "line_support": tolerances.line_support}
    worst = {name: float(worst[name]) for name in UNITS}
    passed = {name: bool(worst[name] >= bound if name in MINIMA else worst[name] <= bound)
              for name, bound in tolerance.items()}
    return CentroidalCheck(worst=worst, tolerance=tolerance, passed=passed)


def _max(values) -> float:
    """Largest entry, 0 for an empty array."""
    return float(np.max(values, initial=0.0))


def _node_samples(t: np.ndarray, node_times: np.ndarray) -> np.ndarray:
    """Indices of the samples at the node times (within 1 µs)."""
    k = np.clip(np.searchsorted(t, node_times), 1, len(t) - 1)
    nearest = np.where(np.abs(t[k - 1] - node_times) <= np.abs(t[k] - node_times), k - 1, k)
    return sorted_unique(nearest[np.abs(t[nearest] - node_times) <= 1e-6])


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
    """Largest component (n,) of the force residual m(c̈ + g e_z) − Σ f_i (N) and of the torque
    residual I_W ω̇ + ω × I_W ω − Σ (p_i − c) × f_i (N·m) about the CoM c = p + R o (o the
    CoM in the base frame, `com_offset`), c̈ = p̈ + ω̇ × R o + ω × (ω × R o), I_W = R I_B Rᵀ."""
    arm = rot @ np.asarray(model.com_offset, float)
    com = p + arm
    com_acc = acc + np.cross(omega_dot, arm) + np.cross(omega, np.cross(omega, arm))
    linear = model.mass * (com_acc + [0.0, 0.0, GRAVITY]) - forces.sum(axis=1)
    inertia = rot @ model.inertia @ np.swapaxes(rot, 1, 2)
    angular = (np.einsum("nij,nj->ni", inertia, omega_dot)
               + np.cross(omega, np.einsum("nij,nj->ni", inertia, omega))
               - np.cross(feet - com[:, None], forces).sum(axis=1))
    return np.abs(linear).max(axis=1), np.abs(angular).max(axis=1)


def _terrain_normal(terrain_map, xy: np.ndarray) -> np.ndarray:
    """Unit normal (..., 3) of the bilinear heightmap at xy (..., 2), TOWR's n ∝ (−h_x, −h_y, 1), the
    gradient by central differences of `height_at`."""
    flat = xy.reshape(-1, 2)
    dx, dy = np.array([HEIGHT_STEP, 0.0]), np.array([0.0, HEIGHT_STEP])
    hx = (terrain_map.height_at(flat + dx) - terrain_map.height_at(flat - dx)) / (2 * HEIGHT_STEP)
    hy = (terrain_map.height_at(flat + dy) - terrain_map.height_at(flat - dy)) / (2 * HEIGHT_STEP)
    n = np.stack([-hx, -hy, np.ones_like(hx)], axis=1)
    return (n / np.linalg.norm(n, axis=1, keepdims=True)).reshape(xy.shape[:-1] + (3,))


def _forces(model, terrain_map, feet, forces, contact) -> dict[str, float]:
    """Force bounds and the Coulomb cone of stance feet, and swing-foot forces, relative to
    max(f·n, m g / 4)."""
    share = model.mass * GRAVITY / 4.0
    n = _terrain_normal(terrain_map, feet[..., :2])
    fn = np.sum(forces * n, axis=-1)
    scale = np.maximum(fn, share)
    tangential = forces - fn[..., None] * n
    bounds = np.maximum(-fn, fn - model.max_normal_force)
    cone = np.linalg.norm(tangential, axis=-1) - model.friction * fn
    return {"normal_force": _max(np.maximum(bounds[contact], 0.0) / scale[contact]),
            "friction_cone": _max(np.maximum(cone[contact], 0.0) / scale[contact]),
            "swing_force": _max(np.linalg.norm(forces[~contact], axis=-1) / share)}


class _Columns:
    """The exact distance to the map's column solid (`ColumnDistance`) near a set of points: the
    heightmap cropped to the points' box grown by the reach (columns farther than the reach change
    no distance up to it, so the values are those of the whole map), built per query set."""

    def __init__(self, terrain_map):
        self.map = terrain_map

    def distance(self, points: np.ndarray, reach: float) -> np.ndarray:
        """Signed distance (m) of points (n, 3), exact up to `reach`, saturated there."""
        grid = self.map.grid
        r, origin = float(grid.resolution), np.asarray(grid.origin, float)[:2]
        ny, nx = np.shape(self.map.height)
        if not len(points):
            return np.zeros(0)
        lo = np.floor((points[:, :2].min(axis=0) - reach - origin) / r).astype(int) - 1
        hi = np.ceil((points[:, :2].max(axis=0) + reach - origin) / r).astype(int) + 1
        lo, hi = np.clip(lo, 0, [nx - 1, ny - 1]), np.clip(hi, 0, [nx - 1, ny - 1])
        height = np.asarray(self.map.height, float)[lo[1]:hi[1] + 1, lo[0]:hi[0] + 1]
        return ColumnDistance(height, origin + r * lo, r, reach).values(points)


def _feet_on_terrain(terrain_map, columns: _Columns, feet, contact) -> dict[str, float]:
    """Stance slip, stance feet on the terrain, and any foot's depth below it (the bilinear height
    field and the exact column solid)."""
    n, legs = contact.shape
    index = np.arange(n)[:, None]
    began = contact & ~np.vstack([np.zeros((1, legs), bool), contact[:-1]])
    first = np.maximum.accumulate(np.where(began, index, 0), axis=0)   # sample where the phase began
    slip = np.linalg.norm(feet - feet[first, np.arange(legs)], axis=-1)
    points = feet.reshape(-1, 3)
    gap = (points[:, 2] - terrain_map.height_at(points[:, :2])).reshape(n, legs)
    exact = columns.distance(points, SPHERE_REACH).reshape(n, legs)
    return {"stance_slip": _max(slip[contact]), "stance_height": _max(np.abs(gap[contact])),
            "stance_column": _max(np.abs(exact[contact])), "penetration_height": _max(np.maximum(-gap, 0.0)),
            "penetration_column": _max(np.maximum(-exact, 0.0))}


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


def _kinematics(robot, p, rot, joints):
    """Sphere centres and foot Jacobians (`legplan.robots.kinematics.Kinematics`) by one pinocchio
    pass over the configurations of the base poses and the IK joints."""
    Q = np.empty((len(p), robot.nq))
    Q[:, :3], Q[:, 3:7], Q[:, 7:] = p, [pin.Quaternion(r).coeffs() for r in rot], joints   # (x, y, z, w)
    return robot.kinematics(Q)


def _joint_torque(robot, model, limits, jacobians, forces, contact) -> float:
    """Largest |Jᵀ f|_j / τ_max,j over the stance feet's legs (forces and contact from `model.legs`
    to `robot.legs` order by name), τ_max the per-leg `limits` (`robot.legs` order; None: the URDF's
    efforts), joints with a positive finite limit."""
    efforts = np.asarray(robot.model.effortLimit, float)
    worst = 0.0
    for k, leg in enumerate(robot.legs):
        m = model.legs.index(leg.name)
        columns = list(leg.joint_idx_v)
        limit = efforts[columns] if limits is None else np.asarray(limits[k], float)
        judged = np.isfinite(limit) & (limit > 0)
        tau = np.einsum("naj,na->nj", jacobians[:, k][:, :, columns], forces[:, m])[contact[:, m]]
        worst = max(worst, _max(np.abs(tau[:, judged]) / limit[judged]))
    return worst


def _spheres(robot, columns: _Columns, centres) -> dict[str, float]:
    """How deep the trunk's and the legs' spheres (all but the feet) reach into the terrain (radius −
    the exact column distance of the centre), the centres (n, spheres, 3) placed by pinocchio FK of
    the base pose and the IK joints."""
    index, foot = np.asarray(robot.spheres.leg_index), np.asarray(robot.spheres.is_foot, bool)
    picked = np.flatnonzero(~foot)
    centres = centres[:, picked]
    radii = np.asarray(robot.spheres.radii, float)[picked]
    reach = float(radii.max(initial=0.0)) + SPHERE_REACH
    depth = radii - columns.distance(centres.reshape(-1, 3), reach).reshape(len(centres), -1)
    trunk = index[picked] == -1
    return {"trunk_penetration": float(depth[:, trunk].max(initial=-np.inf)),
            "leg_penetration": float(depth[:, ~trunk].max(initial=-np.inf))}


def _line_support(t: np.ndarray, contact: np.ndarray) -> float:
    """Longest time (s) the same one or two feet are the only ones in contact: the samples of each
    such run, each counted for the sample spacing."""
    if len(t) < 2:
        return 0.0
    dt = median(np.diff(t))
    count = contact.sum(axis=1)
    longest, run = 0, 0
    for k in range(len(t)):
        line = 1 <= count[k] <= 2
        run = run + 1 if line and k and np.array_equal(contact[k], contact[k - 1]) else int(line)
        longest = max(longest, run)
    return longest * dt


def _base_height(model, robot) -> float:
    """The nominal base height (m) of the centroidal model, or of the robot's `centroidal` section."""
    height = getattr(model, "base_height", None)
    return float(height if height is not None else robot.centroidal.base_height)
