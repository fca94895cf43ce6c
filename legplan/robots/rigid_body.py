"""The single rigid body a legged robot's URDF implies at its nominal stance: the numbers of the
`centroidal:` section (legplan.robots.centroidal), as `robot init` drafts them and as `robot check`
and the robot loader hold a written section against them.

- Composite body (`composite_body`): total mass, the CoM in the base frame and the composite
  rotational inertia about the CoM in the base frame, from pinocchio's composite rigid body
  algorithm (`pin.ccrba`: the centroidal inertia Ig at q with zero velocity), and the feet in the
  base frame (forward kinematics).
- Force limits: the joints' efforts (`torque_limits_of`), which the planner holds |Jᵀ f| to through
  each leg's Jacobian at its planned joints, and a cap of `FORCE_CAP_WEIGHTS` robot weights on the
  normal force (`drafted_force_limit`). `leg_forces`: the largest vertical push f each foot can
  give at the stance with every joint inside its effort limit, τ = Jᵀ f (J the foot's linear
  Jacobian in the world-aligned frame, the leg's columns): f = min_j τ_max,j / |J_zj|, what
  `robot check` holds a scalar bound without torque limits to. Efforts are placeholders when missing,
  or when they would let one leg push more than `PLACEHOLDER_WEIGHTS` times the robot's weight
  (no actuator of a walking robot comes near that; Solo12's URDF gives 1000 N m).
- Range of motion (`reach_box`): half extents (x, y, z) of the largest box, centred on each
  nominal foot, whose corners, edge midpoints and face centres (`box_points`) each leg reaches by
  IK inside its planning joint limits (`legplan.robots.legik`): per axis `REACH_FRACTION` of the
  shortest reach along ±axis, at most `NEIGHBOUR_FRACTION` of the distance to the nearest foot
  along that axis, shrunk until all those points are reached. The reach along a direction is the
  last of `REACH_STEPS` equal steps up to the leg length reached (IK from the nominal stance)
  without a miss before it. IK from the nominal stance alone suffices: a point it reaches is
  reachable, and one it misses only shrinks the box.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from legplan.robots.legik import leg_reach

GRAVITY = 9.81              # m/s^2
PLACEHOLDER_WEIGHTS = 10.0  # a leg pushing more than this many robot weights: efforts are placeholders
FORCE_CAP_WEIGHTS = 4.0     # drafted max_normal_force at most this many robot weights
REACH_FRACTION = 0.6        # of the reach along each axis, the box's half extent
NEIGHBOUR_FRACTION = 0.25   # of the distance to the nearest foot along an axis, the box's half extent
REACH_STEPS = 40           # distances tried along each axis, up to the leg length
SHRINK = 0.9
COM_TOLERANCE = 5e-3        # m, centroidal.com_offset vs the URDF's CoM at the stance
INERTIA_TOLERANCE = 0.05    # relative (Frobenius), centroidal.inertia vs the URDF's composite inertia
FEET_TOLERANCE = 5e-3       # m, centroidal.nominal_feet vs the feet of the nominal stance


@dataclass(frozen=True)
class CompositeBody:
    """The robot as one rigid body at configuration q: `mass` (kg), `com` (3,) and `feet`
    (n_legs, 3) in the base frame (m), `inertia` (3, 3) about the CoM in the base frame (kg m^2)."""

    mass: float
    com: np.ndarray
    inertia: np.ndarray
    feet: np.ndarray


def composite_body(model: pin.Model, q: np.ndarray, foot_frame_ids) -> CompositeBody:
    """`CompositeBody` of a pinocchio model (free-flyer base) at q (module docstring)."""
    data = model.createData()
    pin.ccrba(model, data, q, np.zeros(model.nv))
    pin.updateFramePlacements(model, data)
    base = data.oMi[1]
    rotation = base.rotation
    feet = np.array([base.actInv(data.oMf[int(f)].translation) for f in foot_frame_ids])
    return CompositeBody(mass=float(data.Ig.mass), com=base.actInv(data.com[0]),
                         inertia=rotation.T @ data.Ig.inertia @ rotation, feet=feet)


def urdf_contradictions(model: pin.Model, q: np.ndarray, foot_frame_ids, centroidal, legs=()) -> list[tuple[str, str]]:
    """(field, message) per field of a `Centroidal` that contradicts the URDF at the nominal stance q
    beyond its tolerance: com_offset, inertia, nominal_feet (the mass is checked when parsed), and
    with the robot's `legs` (`legplan.robots.spec.Leg`) a torque limit above its joint's effort."""
    body = composite_body(model, q, foot_frame_ids)
    found = torque_contradictions(model, legs, centroidal) if legs else []
    gap = float(np.linalg.norm(centroidal.com_offset - body.com))
    if gap > COM_TOLERANCE:
        found.append(("centroidal.com_offset", f"is {_vec(centroidal.com_offset)} m but the URDF's CoM at the "
                      f"nominal stance is at {_vec(body.com)} m in the base frame ({gap * 1e3:.1f} mm away)"))
    error = float(np.linalg.norm(centroidal.inertia - body.inertia) / np.linalg.norm(body.inertia))
    if error > INERTIA_TOLERANCE:
        diagonal = np.diag(body.inertia)
        found.append(("centroidal.inertia", f"differs by {error:.0%} from the URDF's composite inertia at the "
                      f"nominal stance (ixx, iyy, izz = {_vec(diagonal, 4)} kg m^2; tolerance "
                      f"{INERTIA_TOLERANCE:.0%})"))
    for leg, written, actual in zip(centroidal.legs, centroidal.nominal_feet, body.feet):
        gap = float(np.linalg.norm(written - actual))
        if gap > FEET_TOLERANCE:
            found.append((f"centroidal.nominal_feet.{leg}", f"is {_vec(written)} m but the nominal stance puts "
                          f"the foot at {_vec(actual)} m ({gap * 1e3:.1f} mm away)"))
    return found


def torque_contradictions(model: pin.Model, legs, centroidal) -> list[tuple[str, str]]:
    """(field, message) per leg of `centroidal.torque_limits` with a bound above its joint's URDF
    effort (`model.effortLimit`): the planner would ask for torques the robot does not have."""
    if centroidal.torque_limits is None:
        return []
    efforts = np.asarray(model.effortLimit, float)
    found = []
    for leg, limits in zip(legs, centroidal.torque_limits):
        above = [f"{name} {limit:g} > {efforts[v]:g}" for name, limit, v in zip(leg.joint_names, limits, leg.joint_idx_v)
                 if limit > efforts[v] * (1 + 1e-9)]
        if above:
            found.append((f"centroidal.torque_limits.{leg.name}", f"exceeds the URDF's joint efforts (N m: "
                          f"{', '.join(above)})"))
    return found


def torque_limits_of(robot) -> tuple | None:
    """Per leg its joints' URDF efforts (N m), the drafted `torque_limits`; None when an effort of
    the legs is a placeholder (`leg_forces`)."""
    if leg_forces(robot).placeholder:
        return None
    efforts = np.asarray(robot.model.effortLimit, float)
    return tuple(efforts[list(leg.joint_idx_v)] for leg in robot.legs)


def torque_limits(robot) -> tuple | None:
    """The joint torque limits `robot` (a `RobotModel`) has, per leg (`robot.legs` order; N m, each
    leg's joints in order): robot.yaml's `centroidal.torque_limits` where given, else the URDF's joint
    efforts (`torque_limits_of`); None when neither bounds the joints (no `centroidal` section and
    placeholder efforts, or placeholder efforts alone). The one rule the planner's torque polytope
    (`legplan.dyn.tasks.centroidal_model`), the independent check's `joint_torque` and the
    simulator's motors (`joint_efforts`) all read, so that a plan the check passes asks no joint for
    more than the simulated robot gives."""
    written = None if robot.centroidal is None else robot.centroidal.torque_limits
    if written is not None:
        order = list(robot.centroidal.legs)
        return tuple(np.asarray(written[order.index(leg.name)], float) for leg in robot.legs)
    return torque_limits_of(robot)


def joint_efforts(robot) -> np.ndarray:
    """Per actuated joint (`robot.joint_names` order) its torque limit (N m): the legs' joints'
    `torque_limits`, every other joint its URDF effort (a placeholder effort stays as written)."""
    efforts = np.array(robot.model.effortLimit, float)
    for leg, limits in zip(robot.legs, torque_limits(robot) or ()):
        efforts[list(leg.joint_idx_v)] = limits
    return efforts[6:]


@dataclass(frozen=True)
class LegForces:
    """Per leg: `force` (N) the largest vertical push inside the effort limits, `joint` the joint
    that limits it; `placeholder` names the joints whose efforts are placeholders (module docstring)."""

    force: np.ndarray
    joint: tuple[str, ...]
    placeholder: tuple[str, ...]

    def usable(self) -> bool:
        return not self.placeholder


def leg_forces(robot) -> LegForces:
    """`LegForces` of a `RobotModel` at its nominal stance."""
    jac = robot.foot_jacobians(robot.q_nominal)[0]
    efforts = np.asarray(robot.model.effortLimit, float)
    weight = robot.mass * GRAVITY
    forces, limiting, placeholder = [], [], []
    for k, leg in enumerate(robot.legs):
        columns = [6 + j for j in leg.joint_idx]
        lever = np.abs(jac[k, 2, columns])
        tau = efforts[columns]
        bad = [name for name, t in zip(leg.joint_names, tau) if not np.isfinite(t) or t <= 0 or t > 1e300]
        usable = lever > 1e-9
        ratio = np.where(usable, tau / np.where(usable, lever, 1.0), np.inf)
        j = int(np.argmin(ratio))
        forces.append(float(ratio[j]))
        limiting.append(leg.joint_names[j])
        if bad:
            placeholder += bad
        elif ratio[j] > PLACEHOLDER_WEIGHTS * weight:
            placeholder += list(leg.joint_names)
    return LegForces(np.array(forces), tuple(limiting), tuple(placeholder))


def drafted_force_limit(robot) -> float:
    """max_normal_force for a draft: `FORCE_CAP_WEIGHTS` robot weights, rounded down to 1 N (the
    joints' efforts bound the forces through the legs, `torque_limits_of`, where they are usable)."""
    return float(np.floor(FORCE_CAP_WEIGHTS * robot.mass * GRAVITY))


def _feet_world(feet, offsets):
    """Targets (n, n_legs, 3): each leg's nominal foot plus each offset (n, 3)."""
    return feet[None, :, :] + np.asarray(offsets, float)[:, None, :]


def _reached(robot, feet, offsets, starts: int | None = None) -> np.ndarray:
    """(n, n_legs) whether each leg reaches its nominal foot + offsets[i] (base level at the origin)
    by IK from `starts` starts (`leg_reach`)."""
    n = len(offsets)
    result = leg_reach(robot, np.zeros((n, 3)), np.tile(np.eye(3), (n, 1, 1)), _feet_world(feet, offsets),
                       starts=starts)
    return result.reachable


def box_points(range_of_motion) -> np.ndarray:
    """(26, 3) offsets of the box of half extents `range_of_motion`: its corners, edge midpoints
    and face centres (the 3 × 3 × 3 grid's surface), corners first. A leg's workspace is not
    convex: a leg that reaches all corners can miss an edge's middle (HyQ, whose hip lifts a foot
    fore and aft only with a sideways swing)."""
    grid = [(sx, sy, sz) for sx in (-1, 0, 1) for sy in (-1, 0, 1) for sz in (-1, 0, 1) if (sx, sy, sz) != (0, 0, 0)]
    signs = np.array(sorted(grid, key=lambda g: -sum(map(abs, g))), float)
    return signs * np.asarray(range_of_motion, float)


def unreachable_points(robot, feet, range_of_motion, starts: int | None = None) -> np.ndarray:
    """(26, n_legs) True where a leg does not reach a point of `box_points` of the box around its
    nominal foot `feet` (n_legs, 3, base frame) by IK from `starts` starts (None: all of
    `leg_reach`'s)."""
    return ~_reached(robot, np.asarray(feet, float), box_points(range_of_motion), starts)


def reach_box(robot, feet) -> np.ndarray:
    """Half extents (3,) of the drafted range-of-motion box around the nominal feet `feet`
    (n_legs, 3, base frame), see the module docstring."""
    feet = np.asarray(feet, float)
    directions = np.vstack([np.eye(3), -np.eye(3)])
    steps = np.arange(1, REACH_STEPS + 1) / REACH_STEPS * robot.leg_length
    offsets = (directions[:, None, :] * steps[None, :, None]).reshape(-1, 3)
    ok = _reached(robot, feet, offsets, starts=1).all(axis=1).reshape(len(directions), REACH_STEPS)
    first_miss = np.where(ok.all(axis=1), REACH_STEPS, np.argmin(ok, axis=1))      # steps reached in a row
    reach = np.where(first_miss > 0, steps[np.maximum(first_miss - 1, 0)], 0.0)
    box = REACH_FRACTION * np.minimum(reach[:3], reach[3:])
    for axis in range(2):
        gaps = np.abs(feet[:, None, axis] - feet[None, :, axis])
        gaps = gaps[gaps > 0.1 * robot.leg_length]          # the feet ahead / beside, not a neighbour's twin
        if len(gaps):
            box[axis] = min(box[axis], NEIGHBOUR_FRACTION * gaps.min())
    for _ in range(30):
        if not unreachable_points(robot, feet, box, starts=1).any():    # reached: proven
            return np.floor(box * 1e3) / 1e3
        box *= SHRINK
    return np.zeros(3)


def _vec(values, digits: int = 3) -> str:
    return "(" + ", ".join(f"{v:.{digits}f}" for v in values) + ")"
