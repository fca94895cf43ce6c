"""Drafting a robot.yaml from a URDF (`legplan robot init`): the rules, each a function.

- Legs (`leg_chains`): the kinematic tree's branches from the floating base to its leaves; every
  actuated joint on one branch. A branch that splits below the base is refused. Four legs are
  ordered left front, right front, left hind, right hind by their hips (the order of the centroidal
  planner's gaits); other counts keep the tree's order.
- Leg names (`leg_names`): the name token all joints of a chain share and the other chains do not,
  as the URDF writes it ("LF_HAA", "LF_KFE" -> "LF"), else leg0, leg1, ...
- Feet (`DraftFoot`): a link or frame moved by the chain's last joint whose name contains "foot"
  (any case; the farthest from the joint when several), with the contact point at the lowest point
  of its geometry in the nominal stance (a sphere's bottom; its origin when it has no geometry).
  Without one, the far end of the last link's primitive geometry (the centre of the extreme face
  along the direction from the joint to the geometry's centre), or for mesh-only links the lowest
  mesh vertex in the nominal stance. `--foot LEG=LINK[:X,Y,Z]` overrides. Written as
  `foot: {link, offset}` (a frame `<leg>_foot` is added at load time, `<leg>_contact` when the URDF
  has a `<leg>_foot` already); the URDF is not edited.
- Collision spheres (`primitive_spheres`): per box a row (or grid) over its two longest edges, per
  cylinder a row along its axis, at most `MAX_SPHERES_PER_SHAPE` along an edge, as many as the
  radius needs to span it (rounded up: a flat plate gets two rows, not one row of spheres as wide
  as the plate, which would reach far below it); the radius is half the thickness (box: at least
  a quarter of the middle edge) or more, so the spheres touch along each edge; a sphere stays a sphere; a mesh-only link is covered as the box around its vertices;
  spheres under `SMALLEST_SPHERE` of the leg length (sensor markers) and spheres inside another
  sphere moved by the same joint are left out.
  A foot sphere sits on each foot point (the foot link's sphere radius, else half the smallest
  sphere of the last link). Leg spheres closer to the ground than the size-scaled clearance in the
  nominal stance are dropped (the foot sphere covers the tip).
- Nominal stance (`solve_stance`): base level at height h, each foot on z = 0. A leg that hangs
  below its hip at the zero configuration keeps its foot's (x, y) there (the hip's lateral offsets
  respected) at a share, the stance depth, of the deepest drop below the hip it reaches there
  inside the joint limits (that of the zero configuration when the limits hold it, else fitted by
  the leg's IK: a knee whose limits stop it short of straight bends more), knee bent towards the
  body's centre unless the joint limits decide; a leg that spreads sideways puts its foot at half
  its horizontal reach, hip-to-foot distance `REACH_FRACTION` × chain length, knee highest. h is
  the legs' mean (or `--height`); each leg is a least-squares IK inside the joint limits from
  several starts. When the contact point is the lowest point of the foot's geometry, the stance
  is solved twice: with the foot link's origin, then with the contact point found there, at the
  same (x, y), the base raised by the contact point's depth (the legs keep their bend).
- Stance depth (`drafted`): bent knees give the range of motion room (a box around the nominal
  foot, so a foot near the bottom of its reach has no room to step down), straight ones let the
  joints push harder. Of `STANCE_DEPTHS` the draft takes the one whose range-of-motion box is the
  largest among those at which every leg can push `TROT_WEIGHT_SHARE` of the robot's weight
  vertically inside its joint efforts (where no depth lets them, the one at which they push
  hardest); placeholder efforts bound nothing. Without a centroidal section, or with `--height`,
  the first.
- Joint limits (`sanitized_limits`): the URDF's (a joint without a range, lower = upper, is refused),
  except a revolute range of 2π or more (not a physical stop): the knee (a leg's last joint) from nearly stretched (`KNEE_MARGIN`) to folded
  (`KNEE_FOLD`) on its nominal side, other joints the nominal angle ± π/2; a warning names them.
- Centroidal section (`legplan.robots.rigid_body`): mass, composite inertia about the CoM and the
  CoM offset at the stance (pinocchio's ccrba), nominal feet, a range-of-motion box whose corners,
  edge midpoints and face centres the legs reach by IK, friction `DRAFT_FRICTION`, and the force limits: the URDF's joint
  efforts as `torque_limits` (the planner keeps |Jᵀf| inside them through each leg's Jacobian) with
  max normal force `FORCE_CAP_WEIGHTS` robot weights; with placeholder efforts (flagged) no torque
  limits and that cap, or `--max-normal-force`.
"""

from __future__ import annotations

import math
import os
import tempfile
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import pinocchio as pin
from scipy.optimize import least_squares

from legplan.errors import LegplanError
from legplan.robots.model import chain_length
from legplan.robots.sizing import size_scaled
from legplan.robots.spec import add_foot_frame
from legplan.robots.urdf import Primitive, UrdfLinks, read_urdf_links
from legplan.robots.urdf_model import UrdfParseError, build_free_flyer_model

MAX_SPHERES_PER_SHAPE = 3
STANCE_STARTS = 6
REACH_FRACTION = 0.75      # hip-to-foot distance / chain length in the nominal stance of a spread leg
STANCE_DEPTHS = (0.75, 0.8, 0.7, 0.65)   # foot depth below the hip / the deepest drop inside the joint
                                         # limits, hanging legs: the candidates of `drafted`, the first
                                         # without a choice
TROT_WEIGHT_SHARE = 1.0 / (2 * 0.8)  # of the robot's weight: what a leg of TOWR's flying trot (a diagonal
                                    # pair stands 0.8 of each second) pushes on average over its stance
DROP_XY_WEIGHT = 100.0     # the deepest drop's fit: weight of the foot's (x, y) against its depth ...
DROP_XY_TOLERANCE = 1e-3   # m, ... and how near (x, y) it must stay
FOOT_ON_GROUND = 5e-4      # m, |z| of every foot after rounding the drafted stance
KNEE_MARGIN = 0.1          # rad, sanitized knee range: from this far from stretched ...
KNEE_FOLD = 2.7            # rad, ... to this far (folded)
DRAFT_FRICTION = 0.5       # friction coefficient of a draft (TOWR's default)
FOOT_WORD = "foot"
SMALLEST_SPHERE = 0.02     # of the mean leg length: smaller spheres (markers, sensors) are not drafted


@dataclass(frozen=True)
class DraftOptions:
    """What the command line sets: `feet` leg name -> (link, offset or None for the lowest point of
    the link's geometry), the base `height` (m), `package_paths` searched for `package://`, and
    the centroidal `friction` and `max_normal_force` (None: from the joint efforts); `centroidal`
    False drafts no centroidal section."""

    feet: dict = field(default_factory=dict)
    height: float | None = None
    package_paths: tuple = ()
    friction: float = DRAFT_FRICTION
    max_normal_force: float | None = None
    centroidal: bool = True


@dataclass(frozen=True)
class LegDraft:
    name: str
    joints: tuple[str, ...]
    foot_link: str
    foot_offset: np.ndarray
    foot_frame: str


@dataclass(frozen=True)
class SphereDraft:
    link: str
    offset: np.ndarray
    radius: float


@dataclass(frozen=True)
class RobotDraft:
    """Everything `draft_yaml` writes; `warnings` are printed by `robot init`."""

    name: str
    urdf: Path
    legs: tuple[LegDraft, ...]
    spheres: tuple[SphereDraft, ...]
    limits: dict[str, tuple[float, float]]
    sanitized: tuple[str, ...]
    base_height: float
    joints: dict[str, list[float]]
    mesh_links: tuple[str, ...]
    centroidal: dict | None = None
    warnings: tuple[str, ...] = ()


def leg_chains(model: pin.Model, urdf: Path) -> list[list[int]]:
    """Joint ids of every branch from the floating base (joint 1) to a leaf, in tree order."""
    chains = []
    for first in model.children[1]:
        chain = [int(first)]
        while len(model.children[chain[-1]]) == 1:
            chain.append(int(model.children[chain[-1]][0]))
        if len(model.children[chain[-1]]) > 1:
            raise LegplanError(f"{urdf}: the chain from joint '{model.names[first]}' branches at joint "
                               f"'{model.names[chain[-1]]}'; a leg must be a chain (write its legs by hand)")
        chains.append(chain)
    if not chains:
        raise LegplanError(f"{urdf}: no joint below the base link; nothing to make legs of")
    return chains


def leg_names(joint_names: list[list[str]]) -> list[str]:
    """Per chain, the name token all its joints share and no other chain's joints have (as written)."""
    tokens = [[set(name.replace("-", "_").split("_")) for name in chain] for chain in joint_names]
    names = []
    for i, chain in enumerate(tokens):
        shared = set.intersection(*chain)
        others = set().union(*(t for j, other in enumerate(tokens) if j != i for t in other))
        own = sorted(t for t in shared - others if t)
        names.append(own[0] if len(own) == 1 else f"leg{i}")
    return names if len(set(names)) == len(names) else [f"leg{i}" for i in range(len(names))]


def quadruped_order(hips: np.ndarray) -> list[int]:
    """Indices of four legs (hip positions (4, 3) in the base frame) as left front, right front, left
    hind, right hind; the tree order when the hips are not two in front and two on the left."""
    centre = hips.mean(axis=0)
    order = []
    for front, left in ((True, True), (True, False), (False, True), (False, False)):
        match = [k for k, h in enumerate(hips) if (h[0] > centre[0]) == front and (h[1] > centre[1]) == left]
        if len(match) != 1:
            return list(range(len(hips)))
        order.append(match[0])
    return order


def _attached_links(model: pin.Model, joint: int) -> list[int]:
    return [k for k, frame in enumerate(model.frames)
            if frame.type == pin.FrameType.BODY and frame.parentJoint == joint]


def foot_link(model: pin.Model, joint: int) -> int | None:
    """The frame id of the link moved by `joint` whose name says foot (farthest from the joint)."""
    feet = [k for k in _attached_links(model, joint) if FOOT_WORD in model.frames[k].name.lower()]
    if not feet:
        return None
    return max(feet, key=lambda k: np.linalg.norm(model.frames[k].placement.translation))


def foot_point(model: pin.Model, links: UrdfLinks, joint: int, urdf: Path) -> tuple[str, np.ndarray]:
    """(link name, offset in its frame) of the far end of the geometry on joint `joint`'s links."""
    attached = _attached_links(model, joint)
    shapes = [(k, shape) for k in attached for shape in links.shapes(model.frames[k].name)]
    if not shapes:
        raise LegplanError(f"{urdf}: link(s) {', '.join(model.frames[k].name for k in attached)} "
                           f"of joint '{model.names[joint]}' have no geometry and none is named foot: give the "
                           "foot with --foot LEG=LINK[:X,Y,Z]")
    points = [model.frames[k].placement.act(p) for k, shape in shapes for p in shape.extreme_points()]
    centres = [model.frames[k].placement.act(np.mean(shape.extreme_points(), axis=0)) for k, shape in shapes]
    direction = np.mean(centres, axis=0)
    if np.linalg.norm(direction) < 1e-6:
        raise LegplanError(f"{urdf}: the geometry of joint '{model.names[joint]}' is centred on the joint; "
                           "give the foot with --foot LEG=LINK[:X,Y,Z]")
    direction /= np.linalg.norm(direction)
    reach = np.array(points) @ direction
    far = np.array(points)[reach >= reach.max() - 1e-5].mean(axis=0)   # the far face, to 10 µm
    owner = max(zip(shapes, centres), key=lambda item: item[1] @ direction)[0][0]   # the farthest shape's link
    return model.frames[owner].name, model.frames[owner].placement.actInv(far)


def lowest_point(model: pin.Model, data: pin.Data, links: UrdfLinks, link: str) -> np.ndarray | None:
    """The lowest point of `link`'s geometry at the configuration `data` holds, in the link frame
    (the mean of the points within 0.1 mm of the lowest); None when the link has no geometry."""
    placement = data.oMf[model.getFrameId(link, pin.FrameType.BODY)]
    points = []
    for shape in links.shapes(link):
        if isinstance(shape, Primitive) and shape.kind == "sphere":
            centre = placement.act(shape.placement.translation)
            points.append(centre - [0.0, 0.0, shape.size[0]])
        else:
            points.extend(placement.act(p) for p in shape.extreme_points())
    if not points:
        return None
    points = np.array(points)
    low = points[points[:, 2] <= points[:, 2].min() + 1e-4].mean(axis=0)
    return placement.actInv(low)


def contact_point(model: pin.Model, data: pin.Data, links: UrdfLinks, joint: int, urdf: Path) -> tuple[str, np.ndarray]:
    """(link, offset in its frame) of the foot `robot init` drafts for the leg whose last joint is
    `joint`, at the stance `data` holds: a foot link's lowest point (its origin when it has no
    geometry), else the far end of the last link's primitives, or the lowest point of its meshes."""
    frame = foot_link(model, joint)
    if frame is not None:
        name = model.frames[frame].name
        low = lowest_point(model, data, links, name)
        return name, np.zeros(3) if low is None else low
    link, offset = foot_point(model, links, joint, urdf)
    if not links.primitives.get(link):
        offset = lowest_point(model, data, links, link)
    return link, offset


def primitive_spheres(shape: Primitive) -> list[tuple[np.ndarray, float]]:
    """(centre in the link frame, radius) of the spheres standing for one primitive."""
    if shape.kind == "sphere":
        return [(shape.placement.translation.copy(), shape.size[0])]
    if shape.kind == "cylinder":
        radius, length = shape.size
        edges, axes, thickness = [length], [2], radius
    else:
        order = np.argsort(shape.size)[::-1]
        edges, axes = [shape.size[order[0]], shape.size[order[1]]], [order[0], order[1]]
        thickness = max(shape.size[order[2]] / 2, shape.size[order[1]] / 4)
    counts, radius = [], thickness
    for edge in edges:                 # the longest edge first: its spacing sets the radius
        counts.append(min(MAX_SPHERES_PER_SHAPE, max(1, math.ceil(edge / (2 * radius) - 1e-9))))
        radius = max(radius, edge / (2 * counts[-1]))
    grids = [(np.arange(n) + 0.5) * edge / n - edge / 2 for edge, n in zip(edges, counts)]
    spheres = []
    for coords in np.stack(np.meshgrid(*grids, indexing="ij"), axis=-1).reshape(-1, len(edges)):
        local = np.zeros(3)
        local[axes] = coords
        spheres.append((shape.placement.act(local), float(radius)))
    return spheres


@dataclass(frozen=True)
class _LegGoal:
    target: np.ndarray      # (2,) foot (x, y), world = base frame at the origin
    depth: float            # m, foot below the base origin
    hanging: bool


def _leg_goals(model, chains, feet, lower, upper, depth: float) -> tuple[list[_LegGoal], np.ndarray]:
    """Per leg its stance goal (module docstring), and the hips' centre (x, y); `lower`, `upper` the
    joint limits (nq − 7,), `depth` a hanging foot's share of its deepest drop."""
    data = model.createData()
    pin.framesForwardKinematics(model, data, pin.neutral(model))
    hips = np.array([data.oMi[chain[0]].translation for chain in chains])
    centre = hips[:, :2].mean(axis=0)
    goals = []
    for chain, foot, hip in zip(chains, feet, hips):
        length = chain_length(model, chain, foot)
        foot0 = data.oMf[foot].translation
        drop = hip[2] - foot0[2]
        if drop > 0.5 * length:
            idx = [int(model.idx_qs[j]) - 7 for j in chain]
            if not np.all((lower[idx] <= 0.0) & (upper[idx] >= 0.0)):    # the zero configuration is out of reach
                drop = _deepest_drop(model, chain, foot, foot0[:2].copy(), hip[2], drop, lower, upper)
            goals.append(_LegGoal(foot0[:2].copy(), depth * drop - hip[2], True))
            continue
        out = foot0[:2] - hip[:2]
        direction = out if np.linalg.norm(out) > 0.2 * length else hip[:2] - centre
        norm = np.linalg.norm(direction)
        direction = direction / norm if norm > 1e-9 else np.array([1.0, 0.0])
        radius = 0.5 * np.linalg.norm(out)
        depth = math.sqrt(max((REACH_FRACTION * length) ** 2 - radius ** 2, (0.3 * length) ** 2)) - hip[2]
        goals.append(_LegGoal(hip[:2] + radius * direction, depth, False))
    return goals, centre


def _deepest_drop(model, chain, foot, target, hip_z: float, drop: float, lower, upper) -> float:
    """How far below its hip (at height `hip_z` above the base origin) the foot of a hanging leg
    reaches at `target` (x, y) inside the joint limits: least squares from both knee branches that
    hold the foot at (x, y) (weight `DROP_XY_WEIGHT`) and pull it towards the zero configuration's
    `drop`, which the limits keep it from; the deepest fit within `DROP_XY_TOLERANCE` of (x, y)
    (`drop` when none is)."""
    problem = LegStance(model, chain, foot, target, 0.0)
    lo, hi = lower[[i - 7 for i in problem.idx]] + 1e-3, upper[[i - 7 for i in problem.idx]] - 1e-3
    aim = hip_z - drop

    def residuals(x):
        pin.framesForwardKinematics(model, problem.data, problem.configuration(x))
        p = problem.data.oMf[foot].translation
        return np.concatenate([DROP_XY_WEIGHT * (p[:2] - problem.target), [p[2] - aim]])

    def jacobian(x):
        jac = pin.computeFrameJacobian(model, problem.data, problem.configuration(x), foot,
                                       pin.LOCAL_WORLD_ALIGNED)[:3, problem.columns]
        return np.vstack([DROP_XY_WEIGHT * jac[:2], jac[2:3]])

    depths = []
    for seed in _knee_seeds(len(problem.idx)):
        fit = least_squares(residuals, np.clip(seed, lo, hi), jac=jacobian, bounds=(lo, hi))
        r = residuals(fit.x)
        if np.linalg.norm(r[:2]) / DROP_XY_WEIGHT < DROP_XY_TOLERANCE:
            depths.append(hip_z - (r[2] + aim))
    return max(depths) if depths else drop


def _knee_seeds(n: int) -> list[np.ndarray]:
    """IK starts of an n-joint leg on both knee branches: the last joint ±1 rad, the one before it
    ∓0.5 rad."""
    seeds = []
    for side in (1.0, -1.0):
        bent = np.zeros(n)
        bent[-1] = side
        if n > 1:
            bent[-2] = -0.5 * side
        seeds.append(bent)
    return seeds


class LegStance:
    """One leg's stance IK: joint angles x (k,) of `chain` with the base level at `height`; the
    residuals put the foot frame `foot` on z = 0 (weight `Z_WEIGHT`) at the goal's (x, y), with a
    small pull of the joints towards zero, and `jacobian` is their derivative (pinocchio's foot
    Jacobian, LOCAL_WORLD_ALIGNED, the leg's columns)."""

    Z_WEIGHT = 100.0
    REGULARIZATION = 1e-3

    def __init__(self, model: pin.Model, chain, foot: int, target, height: float):
        self.model, self.data, self.foot = model, model.createData(), foot
        self.idx = [int(model.idx_qs[j]) for j in chain]
        self.columns = [int(model.idx_vs[j]) for j in chain]
        self.target, self.height = np.asarray(target, float), height

    def configuration(self, x) -> np.ndarray:
        q = pin.neutral(self.model)
        q[2] = self.height
        q[self.idx] = x
        return q

    def residuals(self, x) -> np.ndarray:
        pin.framesForwardKinematics(self.model, self.data, self.configuration(x))
        p = self.data.oMf[self.foot].translation
        return np.concatenate([[self.Z_WEIGHT * p[2]], p[:2] - self.target, self.REGULARIZATION * np.asarray(x)])

    def jacobian(self, x) -> np.ndarray:
        jac = pin.computeFrameJacobian(self.model, self.data, self.configuration(x), self.foot,
                                       pin.LOCAL_WORLD_ALIGNED)[:3, self.columns]
        return np.vstack([self.Z_WEIGHT * jac[2:3], jac[:2], self.REGULARIZATION * np.eye(len(self.idx))])


def _solve_leg(model, chain, foot, goal, height, centre, lower, upper, rng):
    """Joint angles of one leg putting its foot on z = 0 at the goal with the base at `height`, or
    None when no start does."""
    problem = LegStance(model, chain, foot, goal.target, height)
    data = problem.data
    idx = [i - 7 for i in problem.idx]
    lo, hi = lower[idx], upper[idx]
    residuals, jacobian, configuration = problem.residuals, problem.jacobian, problem.configuration

    def score(x):
        pin.framesForwardKinematics(model, data, configuration(x))
        knee, hip, tip = (data.oMi[chain[-1]].translation, data.oMi[chain[0]].translation,
                          data.oMf[foot].translation)
        if not goal.hanging:
            return min(data.oMi[j].translation[2] for j in chain[1:])
        return (knee[0] - (hip[0] + tip[0]) / 2) * np.sign(centre[0] - hip[0])

    seed_lo, seed_hi = np.maximum(lo, -math.pi), np.minimum(hi, math.pi)
    seeds = _knee_seeds(len(idx))                 # both knee branches
    seeds.append(np.zeros(len(idx)))
    seeds += [rng.uniform(seed_lo, seed_hi) * 0.5 for _ in range(STANCE_STARTS - len(seeds))]
    found = []
    for k, seed in enumerate(seeds):
        if found and goal.hanging and k >= 2:     # the two knee branches are the answers of a hanging leg
            break
        fit = least_squares(residuals, np.clip(seed, lo + 1e-3, hi - 1e-3), jac=jacobian,
                            bounds=(lo + 1e-3, hi - 1e-3), xtol=1e-12)
        r = residuals(fit.x)
        if abs(r[0]) / LegStance.Z_WEIGHT < 1e-4:
            found.append((float(np.linalg.norm(r[1:3])), score(fit.x), fit.x))
    if not found:
        return None
    best_xy = min(f[0] for f in found)
    return max((f for f in found if f[0] <= best_xy + 1e-3), key=lambda f: f[1])[2]


def solve_stance(model: pin.Model, chains, feet, urdf: Path, height: float | None = None,
                 targets=None, depth: float = STANCE_DEPTHS[0]) -> np.ndarray:
    """The nominal configuration q (nq,): level base, every foot on z = 0 near its goal (at
    `targets` (n_legs, 2) when given), hanging feet at `depth` of their deepest drop."""
    lower, upper = model.lowerPositionLimit[7:], model.upperPositionLimit[7:]
    goals, centre = _leg_goals(model, chains, feet, lower, upper, depth)
    if targets is not None:
        goals = [replace(goal, target=np.asarray(target, float)) for goal, target in zip(goals, targets)]
    base = float(np.mean([g.depth for g in goals])) if height is None else height
    rng = np.random.default_rng(0)
    q = pin.neutral(model)
    q[2] = base
    for chain, foot, goal in zip(chains, feet, goals):
        x = _solve_leg(model, chain, foot, goal, base, centre, lower, upper, rng)
        if x is None:
            where = "--height" if height is not None else "the drafted base height"
            raise LegplanError(f"{urdf}: joint '{model.names[chain[0]]}''s leg cannot put its foot on the ground "
                               f"inside the joint limits at {where} {base:.3f} m; give --height or write "
                               "nominal: in robot.yaml by hand")
        q[[int(model.idx_qs[j]) for j in chain]] = x
    q[7:] = np.round(q[7:], 4)
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    feet_z = np.array([data.oMf[f].translation[2] for f in feet])
    q[2] = round(q[2] - feet_z.mean(), 5)
    pin.framesForwardKinematics(model, data, q)
    worst = max(abs(data.oMf[f].translation[2]) for f in feet)
    if worst > FOOT_ON_GROUND or q[2] <= 0:
        raise LegplanError(f"{urdf}: the drafted stance leaves a foot {worst * 1e3:.1f} mm off the ground "
                           "(legs of different lengths?); write nominal: in robot.yaml by hand")
    return q


def _is_revolute(model: pin.Model, joint: int) -> bool:
    return model.joints[joint].shortname().startswith("JointModelR")


def _straight_angle(model: pin.Model, chain, foot, q) -> float:
    """The last joint's angle at which the foot is farthest from the leg's first joint (stretched)."""
    data = model.createData()
    k = int(model.idx_qs[chain[-1]])
    angles = q[k] + np.linspace(-math.pi, math.pi, 721)
    reach = []
    for angle in angles:
        trial = q.copy()
        trial[k] = angle
        pin.framesForwardKinematics(model, data, trial)
        reach.append(np.linalg.norm(data.oMf[foot].translation - data.oMi[chain[0]].translation))
    return float(angles[int(np.argmax(reach))])


def sanitized_limits(model: pin.Model, chains, feet, q) -> tuple[dict[str, tuple[float, float]], list[str]]:
    """Planning limits per leg joint and the names of the joints whose URDF range was replaced
    (module docstring)."""
    limits, replaced = {}, []
    for chain, foot in zip(chains, feet):
        for position, joint in enumerate(chain):
            k = int(model.idx_qs[joint])
            lo, hi = float(model.lowerPositionLimit[k]), float(model.upperPositionLimit[k])
            if _is_revolute(model, joint) and hi - lo >= 2 * math.pi - 1e-9:
                nominal = float(q[k])
                if position == len(chain) - 1 and len(chain) > 1:
                    straight = _straight_angle(model, chain, foot, q)
                    side = 1.0 if math.remainder(nominal - straight, 2 * math.pi) >= 0 else -1.0
                    ends = sorted([straight + side * KNEE_MARGIN, straight + side * KNEE_FOLD])
                    new = (min(ends[0], nominal), max(ends[1], nominal))
                else:
                    new = (nominal - math.pi / 2, nominal + math.pi / 2)
                lo, hi = max(lo, new[0]), min(hi, new[1])
                replaced.append(model.names[joint])
            limits[model.names[joint]] = (lo, hi)
    return limits, replaced


def _foot_frame_name(model: pin.Model, leg: str) -> str:
    name = f"{leg}_foot"
    return name if not model.existFrame(name) else f"{leg}_contact"


def _choose_feet(model, links, chains, names, options, urdf):
    """Per leg (link, offset, refine): refine = take the lowest point of the link's geometry in the
    stance."""
    chosen = []
    for leg, chain in zip(names, chains):
        if leg in options.feet:
            link, offset = options.feet[leg]
            if not model.existFrame(link, pin.FrameType.BODY):
                raise LegplanError(f"--foot {leg}={link}: {urdf} has no link '{link}'")
            if model.frames[model.getFrameId(link, pin.FrameType.BODY)].parentJoint != chain[-1]:
                raise LegplanError(f"--foot {leg}={link}: link '{link}' is not moved by leg {leg}'s last joint "
                                   f"'{model.names[chain[-1]]}' (only by fixed joints below it)")
            chosen.append((link, np.zeros(3) if offset is None else np.asarray(offset, float), offset is None))
            continue
        frame = foot_link(model, chain[-1])
        if frame is not None:
            name = model.frames[frame].name
            chosen.append((name, np.zeros(3), bool(links.shapes(name))))
            continue
        link, offset = foot_point(model, links, chain[-1], urdf)
        chosen.append((link, offset, not links.primitives.get(link)))
    unknown = sorted(set(options.feet) - set(names))
    if unknown:
        raise LegplanError(f"--foot {unknown[0]}=...: no leg named '{unknown[0]}' in {urdf} (legs: {', '.join(names)})")
    return chosen


def draft_robot(urdf: str | Path, name: str, options: DraftOptions | None = None,
                depth: float = STANCE_DEPTHS[0]) -> RobotDraft:
    """Draft the robot.yaml content for the URDF at `urdf` (see the module docstring), without the
    centroidal section (`draft_centroidal` adds it), hanging feet at `depth` of their deepest drop
    (`drafted` chooses it)."""
    options = options or DraftOptions()
    urdf = Path(urdf)
    if not urdf.is_file():
        raise LegplanError(f"{urdf}: no such URDF file")
    try:
        base_model = build_free_flyer_model(urdf)
    except UrdfParseError as exc:
        raise LegplanError(f"{urdf}: cannot be parsed by pinocchio ({exc})") from None
    for joint in range(2, base_model.njoints):
        if base_model.nqs[joint] != 1 or base_model.nvs[joint] != 1:
            raise LegplanError(f"{urdf}: joint '{base_model.names[joint]}' is not a 1-DoF revolute or prismatic joint "
                               f"(nq={base_model.nqs[joint]}); legs of such joints are not supported")
        k = int(base_model.idx_qs[joint])
        if base_model.upperPositionLimit[k] <= base_model.lowerPositionLimit[k]:
            raise LegplanError(f"{urdf}: joint '{base_model.names[joint]}': its <limit> gives no range (lower "
                               f"{base_model.lowerPositionLimit[k]:g} = upper {base_model.upperPositionLimit[k]:g}; "
                               "a movable joint needs lower < upper); legs of fixed joints cannot be drafted")
    links = read_urdf_links(urdf, options.package_paths)
    chains = leg_chains(base_model, urdf)
    if len(chains) == 4:
        data = base_model.createData()
        pin.forwardKinematics(base_model, data, pin.neutral(base_model))
        chains = [chains[k] for k in quadruped_order(np.array([data.oMi[c[0]].translation for c in chains]))]
    names = leg_names([[base_model.names[j] for j in chain] for chain in chains])
    chosen = _choose_feet(base_model, links, chains, names, options, urdf)
    frames = [_foot_frame_name(base_model, leg) for leg in names]

    def stance(points, height=options.height, targets=None):
        model = pin.Model(base_model)
        feet = [add_foot_frame(model, link, offset, frame) for (link, offset, _), frame in zip(points, frames)]
        return model, feet, solve_stance(model, chains, feet, urdf, height, targets, depth)

    model, feet, q = stance(chosen)
    if any(refine for _, _, refine in chosen):        # the contact point: lowest in this stance
        data = model.createData()
        pin.framesForwardKinematics(model, data, q)
        targets = [data.oMf[f].translation[:2].copy() for f in feet]   # where the first stance put the feet
        refined = []
        for leg, chain, (link, offset, refine) in zip(names, chains, chosen):
            if leg not in options.feet:
                link, offset = contact_point(model, data, links, chain[-1], urdf)
            elif refine:
                low = lowest_point(model, data, links, link)
                offset = np.zeros(3) if low is None else low
            refined.append((link, np.round(offset, 4), refine))
        below = np.mean([data.oMf[model.getFrameId(link, pin.FrameType.BODY)].act(offset)[2]
                         for link, offset, _ in refined])
        chosen = refined
        model, feet, q = stance(chosen, options.height or float(q[2] - below), targets)
    legs = [LegDraft(leg, tuple(model.names[j] for j in chain), link, np.round(offset, 4), frame)
            for leg, chain, (link, offset, _), frame in zip(names, chains, chosen, frames)]
    limits, replaced = sanitized_limits(model, chains, feet, q)
    leg_length = float(np.mean([chain_length(model, c, f) for c, f in zip(chains, feet)]))
    spheres, mesh_links = _spheres(model, links, chains, feet, legs, q, size_scaled("clearance", leg_length))
    joints = {leg.name: [float(q[model.idx_qs[j]]) for j in chain] for leg, chain in zip(legs, chains)}
    warnings = []
    if replaced:
        ranges = [int(base_model.idx_qs[base_model.getJointId(j)]) for j in replaced[:3]]
        shown = ", ".join(f"{j} [{base_model.lowerPositionLimit[k]:g}, {base_model.upperPositionLimit[k]:g}]"
                          for j, k in zip(replaced, ranges))
        warnings.append(f"{urdf}: {len(replaced)} revolute joints have ranges of 2π or more, not physical stops "
                        f"({shown}{', ...' if len(replaced) > 3 else ''}): joint_limits drafted from the stance "
                        "(knees on their bend side, other joints ±π/2)")
    return RobotDraft(name=name, urdf=urdf, legs=tuple(legs), spheres=tuple(spheres), limits=limits,
                      sanitized=tuple(replaced), base_height=float(q[2]), joints=joints,
                      mesh_links=tuple(mesh_links), warnings=tuple(warnings))


def _spheres(model, links, chains, feet, legs, q, clearance) -> tuple[list[SphereDraft], list[str]]:
    smallest = SMALLEST_SPHERE * np.mean([chain_length(model, c, f) for c, f in zip(chains, feet)])
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    leg_joints = {j for chain in chains for j in chain}
    spheres, mesh_links = [], []
    for k, frame in enumerate(model.frames):
        if frame.type != pin.FrameType.BODY:
            continue
        shapes = list(links.primitives.get(frame.name, ()))
        if not shapes and links.meshes.get(frame.name):
            shapes = [mesh.bounding_box() for mesh in links.meshes[frame.name]]
            mesh_links.append(frame.name)
        on_leg = frame.parentJoint in leg_joints
        for shape in shapes:
            for centre, radius in primitive_spheres(shape):
                height = data.oMf[k].act(centre)[2] - radius
                if on_leg and height < clearance:
                    continue                     # at the foot: the foot sphere stands for it
                if radius < smallest:
                    continue                     # a marker (camera, IMU), not a body part
                spheres.append(SphereDraft(frame.name, centre, radius))
    spheres = _uncovered(model, spheres)
    body = list(spheres)
    for leg, chain in zip(legs, chains):
        own = [s.size[0] for s in links.primitives.get(leg.foot_link, ()) if s.kind == "sphere"]
        tip = [s.radius for s in body
               if model.frames[model.getFrameId(s.link, pin.FrameType.BODY)].parentJoint == chain[-1]]
        radius = min(own) if own else 0.5 * min(tip) if tip else 0.01
        spheres.append(SphereDraft(leg.foot_frame, np.zeros(3), max(radius, 0.002)))
    return spheres, mesh_links


def _uncovered(model: pin.Model, spheres: list[SphereDraft]) -> list[SphereDraft]:
    """The spheres not inside another sphere moved by the same joint (the earlier of two equal ones
    stays)."""
    placed = []
    for sphere in spheres:
        frame = model.frames[model.getFrameId(sphere.link, pin.FrameType.BODY)]
        placed.append((frame.parentJoint, frame.placement.act(sphere.offset), sphere.radius))
    keep = []
    for i, (joint, centre, radius) in enumerate(placed):
        inside = any(j != i and other_joint == joint and np.linalg.norm(centre - other) + radius <= other_radius + 1e-9
                     and (radius < other_radius or j < i)
                     for j, (other_joint, other, other_radius) in enumerate(placed))
        if not inside:
            keep.append(spheres[i])
    return keep


def _number(value: float) -> str:
    """`value` to 0.1 mm / 0.1 mrad, without trailing zeros ("0.138", "0", never "-0")."""
    rounded = round(float(value), 4)
    return f"{rounded:.4f}".rstrip("0").rstrip(".") if rounded != 0 else "0"


def _vector(values) -> str:
    return "[" + ", ".join(_number(v) for v in values) + "]"


def draft_yaml(draft: RobotDraft, urdf_ref: str) -> str:
    """robot.yaml text of a draft, with comments saying where each value came from."""
    lines = [f"# Drafted by `legplan robot init {draft.urdf}`: review every section, then run",
             f"# `legplan robot check {draft.name}` (docs/robots.md documents every field).",
             f"name: {draft.name}",
             f"description: drafted from {draft.urdf.name}",
             f"urdf: {urdf_ref}",
             "",
             "# Leg chains: the kinematic tree's branches from the base; feet on the URDF's foot links (their",
             "# lowest point in the stance) or at the far end of the last link's geometry (a frame is added",
             "# to the model, the URDF is not edited).",
             "legs:"]
    for leg in draft.legs:
        frame = "" if leg.foot_frame == f"{leg.name}_foot" else f", frame: {leg.foot_frame}"
        lines.append(f"  - {{name: {leg.name}, joints: [{', '.join(leg.joints)}],")
        lines.append(f"     foot: {{link: {leg.foot_link}, offset: {_vector(leg.foot_offset)}{frame}}}}}")
    lines += ["", "# Planning limits: the URDF's; narrow them to keep the legs apart (no self-collision check)."]
    if draft.sanitized:
        lines.append(f"# Drafted from the stance (URDF range of 2π or more): {', '.join(draft.sanitized)}")
    lines.append("joint_limits:")
    lines += [f"  {joint}: [{math.ceil(lo * 1e4) / 1e4:.4f}, {math.floor(hi * 1e4) / 1e4:.4f}]"  # rounded inwards
              for joint, (lo, hi) in draft.limits.items()]
    lines += ["", "# Spheres along the links' primitive geometry; one small sphere on each foot point."]
    if draft.mesh_links:
        lines.append(f"# Spheres over the box around the mesh of: {', '.join(draft.mesh_links)}")
    lines.append("collision_spheres:")
    lines += [f"  - {{link: {s.link}, offset: {_vector(s.offset)}, radius: {s.radius:.4f}}}"
              for s in draft.spheres]
    lines += ["", "# Nominal stance: level base, feet on z = 0 (solved by least squares).", "nominal:",
              f"  base_height: {draft.base_height:.5f}", "  joints:"]
    lines += [f"    {leg}: {_vector(values)}" for leg, values in draft.joints.items()]
    c = draft.centroidal
    if c is not None:
        lines += ["", "# Single rigid body at the nominal stance (legplan.robots.rigid_body): pinocchio's composite",
                  "# inertia about the CoM, the CoM in the base frame, a range-of-motion box whose corners, edge",
                  f"# midpoints and face centres every leg reaches inside the joint limits, the normal force {c['force_source']}.",
                  "centroidal:",
                  f"  mass: {c['mass']:.10g}",
                  "  inertia: {" + ", ".join(f"{key}: {value:.6g}" for key, value in c["inertia"].items()) + "}",
                  f"  com_offset: {_vector(c['com_offset'])}",
                  "  nominal_feet:"]
        lines += [f"    {leg}: {_vector(foot)}" for leg, foot in c["nominal_feet"].items()]
        lines += [f"  range_of_motion: {_vector(c['range_of_motion'])}",
                  f"  max_normal_force: {c['max_normal_force']:g}",
                  f"  friction: {c['friction']:g}"]
        if c.get("torque_limits") is not None:
            lines.append("  torque_limits:                       # N m, the URDF's joint efforts, per leg")
            lines += [f"    {leg.name}: [{', '.join(f'{v:g}' for v in limits)}]"
                      for leg, limits in zip(draft.legs, c["torque_limits"])]
    return "\n".join(lines) + "\n"


def draft_centroidal(draft: RobotDraft, options: DraftOptions | None = None) -> RobotDraft:
    """The draft with its centroidal section, computed on the drafted robot as it loads."""
    from dataclasses import replace

    from legplan.robots.model import RobotModel
    from legplan.robots.rigid_body import composite_body, drafted_force_limit, leg_forces, reach_box, torque_limits_of

    options = options or DraftOptions()
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "robot.yaml"
        path.write_text(draft_yaml(draft, str(draft.urdf.resolve())))
        robot = RobotModel(_loaded(path, draft.urdf))
    body = composite_body(robot.model, robot.q_nominal, [leg.foot_frame_id for leg in robot.legs])
    if not body.mass > 0:
        raise LegplanError(f"{draft.urdf}: centroidal.mass: the URDF's links have no mass; give them inertials or "
                           "draft with --no-centroidal")
    box = reach_box(robot, body.feet)
    if not np.all(box > 0):
        stuck = "no box around the nominal feet" if not box.any() else \
            f"the feet cannot move along {', '.join('xyz'[k] for k in np.flatnonzero(box <= 0))}"
        raise LegplanError(f"{draft.urdf}: centroidal.range_of_motion: {stuck} inside the joint limits (a centroidal "
                           "model needs a box with three positive extents); draft with --no-centroidal")
    forces = leg_forces(robot)
    warnings = list(draft.warnings)
    if options.max_normal_force is not None:
        force, source = options.max_normal_force, "given on the command line"
    else:
        force = drafted_force_limit(robot)
        source = ("capped (placeholder joint efforts)" if forces.placeholder
                  else "capped, the joint efforts bounding the forces through the leg Jacobians (torque_limits)")
        if forces.placeholder:
            warnings.append(f"{draft.urdf}: joint efforts of {', '.join(forces.placeholder[:3])}"
                            f"{', ...' if len(forces.placeholder) > 3 else ''} are placeholders (missing, or a leg "
                            f"would push {forces.force.max():.0f} N, > 10 robot weights): centroidal.max_normal_force "
                            f"drafted as {force:g} N; give --max-normal-force")
    inertia = body.inertia
    centroidal = {
        "mass": body.mass, "com_offset": body.com,
        "inertia": {"ixx": inertia[0, 0], "iyy": inertia[1, 1], "izz": inertia[2, 2],
                    "ixy": inertia[0, 1], "ixz": inertia[0, 2], "iyz": inertia[1, 2]},
        "nominal_feet": {leg.name: foot for leg, foot in zip(robot.legs, body.feet)},
        "range_of_motion": box, "max_normal_force": force, "friction": options.friction, "force_source": source,
        "torque_limits": torque_limits_of(robot),
        "leg_force": np.inf if forces.placeholder else float(forces.force.min())}
    return replace(draft, centroidal=centroidal, warnings=tuple(warnings))


def drafted(urdf: str | Path, name: str, options: DraftOptions | None = None) -> RobotDraft:
    """The draft `robot init` writes: with a centroidal section and no `--height`, the stance depth
    of `STANCE_DEPTHS` whose legs can each push `TROT_WEIGHT_SHARE` of the robot's weight inside
    their efforts and whose range-of-motion box is the largest (volume); where none can, the one
    whose legs push hardest (module docstring). Otherwise the first depth's."""
    options = options or DraftOptions()
    if not options.centroidal or options.height is not None:
        draft = draft_robot(urdf, name, options)
        return draft_centroidal(draft, options) if options.centroidal else draft
    from legplan.robots.rigid_body import GRAVITY

    best, key, failure, heights = None, None, None, set()
    for depth in STANCE_DEPTHS:
        try:
            draft = draft_robot(urdf, name, options, depth)
            if draft.base_height in heights:          # no hanging leg: the depth changes nothing
                break
            heights.add(draft.base_height)
            draft = draft_centroidal(draft, options)
        except LegplanError as exc:
            failure = failure or exc
            continue
        c = draft.centroidal
        holds = c["leg_force"] >= TROT_WEIGHT_SHARE * c["mass"] * GRAVITY
        rank = (holds, float(np.prod(c["range_of_motion"])) if holds else c["leg_force"])
        if key is None or rank > key:
            best, key = draft, rank
    if best is None:
        raise failure
    return best


def write_draft(urdf: str | Path, folder: str | Path, name: str | None = None, overwrite: bool = False,
                options: DraftOptions | None = None) -> tuple[Path, RobotDraft]:
    """Draft robot.yaml for `urdf` into `folder` (created), naming the URDF by its path relative to
    the folder (absolute when they share no folder but the root). The draft is loaded
    (`read_spec`) before it is published, so a written draft always loads. Returns its path and
    the draft (its warnings)."""
    from legplan.artefacts.publish import staged_output
    from legplan.artefacts.writer import check_output

    folder = Path(folder)
    target = check_output(folder / "robot.yaml", overwrite)
    urdf_abs, folder_abs = Path(urdf).resolve(), folder.resolve()
    related = os.path.commonpath([urdf_abs, folder_abs]) != os.path.sep
    urdf_ref = os.path.relpath(urdf_abs, folder_abs) if related else str(urdf_abs)
    options = options or DraftOptions()
    draft = drafted(urdf, name or folder.resolve().name, options)
    created = not folder.exists()
    folder.mkdir(parents=True, exist_ok=True)
    try:
        with staged_output(target, overwrite=overwrite) as temp:
            Path(temp).write_text(draft_yaml(draft, urdf_ref))
            _loaded(temp, Path(urdf))
    except BaseException:
        if created:
            folder.rmdir()
        raise
    return target, draft


def _loaded(path: Path, urdf: Path):
    """`read_spec` of a draft written to the temporary `path`; its errors name the URDF drafted from
    (the temporary file is gone when the user reads them)."""
    from legplan.robots.spec import read_spec

    try:
        return read_spec(path)
    except LegplanError as exc:
        reason = str(exc).split(f"{path}:", 1)[-1].strip()
        raise LegplanError(f"{urdf}: the draft does not load: {reason}") from None
