"""Drafting a robot.yaml from a URDF (`legplan robot init`): the rules, each a function.

- Legs (`leg_chains`): the kinematic tree's branches from the floating base to its leaves; every
  actuated joint on one branch. A branch that splits below the base is refused.
- Leg names (`leg_names`): the name token all joints of a chain share and the other chains do not
  ("coxa_lf", "femur_lf" -> "lf"), else leg0, leg1, ...
- Feet (`foot_point`): on the links of a chain's last joint, the far end of their geometry
  (collision, else visual): the centre of the extreme face along the direction from the joint to
  the geometry's centre. Written as `foot: {link, offset}`; the URDF is not edited.
- Collision spheres (`primitive_spheres`): per box a row (or grid) over its two longest edges, per
  cylinder a row along its axis, at most `MAX_SPHERES_PER_SHAPE` along an edge; the radius is half
  the thickness (box: at least a quarter of the middle edge) or more, so the spheres touch along
  each edge; a sphere stays a sphere; meshes get none (listed in the draft). A foot sphere sits
  on each foot point. Leg spheres closer to the ground than the size-scaled clearance in the nominal
  stance are dropped (the foot sphere covers the tip).
- Joint limits: the URDF's.
- Nominal stance (`solve_stance`): base level at height h, each foot on z = 0 at half the leg's
  horizontal reach at the zero configuration out from its hip, hip-to-foot distance 0.75 × the
  leg's chain length; a least-squares fit of h and the joints inside their limits from several
  starts, the knee-highest solution kept.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin
from scipy.optimize import least_squares

from legplan.errors import LegplanError
from legplan.robots.model import chain_length
from legplan.robots.sizing import size_scaled
from legplan.robots.spec import add_foot_frame
from legplan.robots.urdf import Primitive, UrdfLinks, UrdfParseError, build_free_flyer_model, read_urdf_links

MAX_SPHERES_PER_SHAPE = 3
STANCE_STARTS = 8
REACH_FRACTION = 0.75      # hip-to-foot distance / chain length in the nominal stance
FOOT_ON_GROUND = 5e-4      # m, |z| of every foot after rounding the drafted stance


@dataclass(frozen=True)
class LegDraft:
    name: str
    joints: tuple[str, ...]
    foot_link: str
    foot_offset: np.ndarray


@dataclass(frozen=True)
class SphereDraft:
    link: str
    offset: np.ndarray
    radius: float


@dataclass(frozen=True)
class RobotDraft:
    """Everything `draft_yaml` writes."""

    name: str
    urdf: Path
    legs: tuple[LegDraft, ...]
    spheres: tuple[SphereDraft, ...]
    limits: dict[str, tuple[float, float]]
    base_height: float
    joints: dict[str, list[float]]
    mesh_links: tuple[str, ...]


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
    """Per chain, the name token all its joints share and no other chain's joints have."""
    tokens = [[set(name.replace("-", "_").split("_")) for name in chain] for chain in joint_names]
    names = []
    for i, chain in enumerate(tokens):
        shared = set.intersection(*chain)
        others = set().union(*(t for j, other in enumerate(tokens) if j != i for t in other))
        own = sorted(t for t in shared - others if t)
        names.append(own[0].lower() if len(own) == 1 else f"leg{i}")
    return names if len(set(names)) == len(names) else [f"leg{i}" for i in range(len(names))]


def _attached_links(model: pin.Model, joint: int) -> list[int]:
    return [k for k, frame in enumerate(model.frames)
            if frame.type == pin.FrameType.BODY and frame.parentJoint == joint]


def foot_point(model: pin.Model, links: UrdfLinks, joint: int, urdf: Path) -> tuple[str, np.ndarray]:
    """(link name, offset in its frame) of the far end of the geometry on joint `joint`'s links."""
    attached = _attached_links(model, joint)
    shapes = [(k, shape) for k in attached for shape in links.primitives.get(model.frames[k].name, ())]
    if not shapes:
        raise LegplanError(f"{urdf}: link(s) {', '.join(model.frames[k].name for k in attached)} "
                           f"of joint '{model.names[joint]}' have no box, cylinder or sphere geometry: "
                           "give the foot in robot.yaml by hand (legs[i].foot: {link, offset})")
    points = [model.frames[k].placement.act(p) for k, shape in shapes for p in shape.extreme_points()]
    centres = [model.frames[k].placement.act(shape.placement.translation) for k, shape in shapes]
    direction = np.mean(centres, axis=0)
    if np.linalg.norm(direction) < 1e-6:
        raise LegplanError(f"{urdf}: the geometry of joint '{model.names[joint]}' is centred on the joint; "
                           "give the foot in robot.yaml by hand")
    direction /= np.linalg.norm(direction)
    reach = np.array(points) @ direction
    far = np.array(points)[reach >= reach.max() - 1e-5].mean(axis=0)   # the far face, to 10 µm
    owner = max(zip(shapes, centres), key=lambda item: item[1] @ direction)[0][0]   # the farthest shape's link
    return model.frames[owner].name, model.frames[owner].placement.actInv(far)


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
        counts.append(min(MAX_SPHERES_PER_SHAPE, max(1, round(edge / (2 * radius)))))
        radius = max(radius, edge / (2 * counts[-1]))
    grids = [(np.arange(n) + 0.5) * edge / n - edge / 2 for edge, n in zip(edges, counts)]
    spheres = []
    for coords in np.stack(np.meshgrid(*grids, indexing="ij"), axis=-1).reshape(-1, len(edges)):
        local = np.zeros(3)
        local[axes] = coords
        spheres.append((shape.placement.act(local), float(radius)))
    return spheres


def _stance_targets(model, data, chains, feet):
    """Per leg the foot target (x, y) and the base height the targets ask for (mean over legs)."""
    q0 = pin.neutral(model)
    pin.framesForwardKinematics(model, data, q0)
    hips = np.array([data.oMi[chain[0]].translation for chain in chains])
    centre = hips[:, :2].mean(axis=0)
    targets, heights = [], []
    for chain, foot, hip in zip(chains, feet, hips):
        length = chain_length(model, chain, foot)
        out = data.oMf[foot].translation[:2] - hip[:2]
        direction = out if np.linalg.norm(out) > 0.2 * length else hip[:2] - centre
        norm = np.linalg.norm(direction)
        direction = direction / norm if norm > 1e-9 else np.array([1.0, 0.0])
        radius = 0.5 * np.linalg.norm(out)
        targets.append(hip[:2] + radius * direction)
        heights.append(math.sqrt(max((REACH_FRACTION * length) ** 2 - radius ** 2, (0.3 * length) ** 2)) - hip[2])
    return np.array(targets), float(np.mean(heights))


def solve_stance(model: pin.Model, chains, feet, urdf: Path) -> np.ndarray:
    """The nominal configuration q (nq,): level base, every foot on z = 0 near its target."""
    data = model.createData()
    targets, height = _stance_targets(model, data, chains, feet)
    lower, upper = model.lowerPositionLimit[7:] + 1e-3, model.upperPositionLimit[7:] - 1e-3

    def configuration(x):
        q = pin.neutral(model)
        q[2], q[7:] = x[0], x[1:]
        return q

    def residuals(x):
        pin.framesForwardKinematics(model, data, configuration(x))
        feet_now = np.array([data.oMf[f].translation for f in feet])
        return np.concatenate([100.0 * feet_now[:, 2], (feet_now[:, :2] - targets).ravel(),
                               [x[0] - height], 1e-3 * x[1:]])

    def knee_height(q):
        pin.framesForwardKinematics(model, data, q)
        return min((data.oMi[j].translation[2] for chain in chains for j in chain[1:]), default=0.0)

    rng = np.random.default_rng(0)
    best, best_score = None, -np.inf
    for start in range(STANCE_STARTS):
        joints = np.clip(np.zeros(len(lower)), lower, upper) if start == 0 else rng.uniform(lower, upper) * 0.5
        x0 = np.concatenate([[height], np.clip(joints, lower, upper)])
        fit = least_squares(residuals, x0, bounds=(np.r_[1e-3, lower], np.r_[np.inf, upper]), xtol=1e-12)
        q = configuration(fit.x)
        pin.framesForwardKinematics(model, data, q)
        if max(abs(data.oMf[f].translation[2]) for f in feet) > 1e-4:
            continue
        score = knee_height(q)
        if score > best_score + 1e-6:
            best, best_score = q, score
    if best is None:
        raise LegplanError(f"{urdf}: no stance inside the joint limits puts every foot on the ground; "
                           "write nominal: in robot.yaml by hand")
    best[7:] = np.round(best[7:], 4)
    pin.framesForwardKinematics(model, data, best)
    feet_z = np.array([data.oMf[f].translation[2] for f in feet])
    best[2] = round(best[2] - feet_z.mean(), 5)
    pin.framesForwardKinematics(model, data, best)
    worst = max(abs(data.oMf[f].translation[2]) for f in feet)
    if worst > FOOT_ON_GROUND or best[2] <= 0:
        raise LegplanError(f"{urdf}: the drafted stance leaves a foot {worst * 1e3:.1f} mm off the ground "
                           "(legs of different lengths?); write nominal: in robot.yaml by hand")
    return best


def draft_robot(urdf: str | Path, name: str) -> RobotDraft:
    """Draft the robot.yaml content for the URDF at `urdf` (see the module docstring)."""
    urdf = Path(urdf)
    try:
        model = build_free_flyer_model(urdf)
    except UrdfParseError as exc:
        raise LegplanError(f"{urdf}: cannot be parsed by pinocchio ({exc})") from None
    links = read_urdf_links(urdf)
    chains = leg_chains(model, urdf)
    names = leg_names([[model.names[j] for j in chain] for chain in chains])
    legs, feet = [], []
    for leg, chain in zip(names, chains):
        link, offset = foot_point(model, links, chain[-1], urdf)
        offset = np.round(offset, 4)
        legs.append(LegDraft(leg, tuple(model.names[j] for j in chain), link, offset))
        feet.append(add_foot_frame(model, link, offset, f"{leg}_foot"))
    q = solve_stance(model, chains, feet, urdf)
    leg_length = float(np.mean([chain_length(model, c, f) for c, f in zip(chains, feet)]))
    spheres = _spheres(model, links, chains, feet, legs, q, size_scaled("clearance", leg_length))
    limits = {model.names[j]: (float(model.lowerPositionLimit[model.idx_qs[j]]),
                               float(model.upperPositionLimit[model.idx_qs[j]]))
              for chain in chains for j in chain}
    joints = {leg.name: [float(q[model.idx_qs[j]]) for j in chain] for leg, chain in zip(legs, chains)}
    return RobotDraft(name=name, urdf=urdf, legs=tuple(legs), spheres=tuple(spheres), limits=limits,
                      base_height=float(q[2]), joints=joints, mesh_links=tuple(sorted(links.meshes)))


def _spheres(model, links, chains, feet, legs, q, clearance) -> list[SphereDraft]:
    data = model.createData()
    pin.framesForwardKinematics(model, data, q)
    leg_joints = {j for chain in chains for j in chain}
    spheres = []
    for k, frame in enumerate(model.frames):
        if frame.type != pin.FrameType.BODY:
            continue
        on_leg = frame.parentJoint in leg_joints
        for shape in links.primitives.get(frame.name, ()):
            for centre, radius in primitive_spheres(shape):
                height = data.oMf[k].act(centre)[2] - radius
                if on_leg and height < clearance:
                    continue                     # at the foot: the foot sphere stands for it
                spheres.append(SphereDraft(frame.name, centre, radius))
    for leg, chain in zip(legs, chains):
        tip = [s.radius for s in spheres if model.frames[model.getFrameId(s.link)].parentJoint == chain[-1]]
        radius = 0.5 * min(tip) if tip else 0.01
        spheres.append(SphereDraft(f"{leg.name}_foot", np.zeros(3), max(radius, 0.002)))
    return spheres


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
             "# Leg chains: the kinematic tree's branches from the base; feet at the far end of the last",
             "# link's geometry (a frame '<leg>_foot' is added to the model, the URDF is not edited).",
             "legs:"]
    for leg in draft.legs:
        lines.append(f"  - {{name: {leg.name}, joints: [{', '.join(leg.joints)}],")
        lines.append(f"     foot: {{link: {leg.foot_link}, offset: {_vector(leg.foot_offset)}}}}}")
    lines += ["", "# Planning limits: the URDF's; narrow them to keep the legs apart (no self-collision",
              "# check).", "joint_limits:"]
    lines += [f"  {joint}: [{math.ceil(lo * 1e4) / 1e4:.4f}, {math.floor(hi * 1e4) / 1e4:.4f}]"  # rounded inwards
              for joint, (lo, hi) in draft.limits.items()]
    lines += ["", "# Spheres along the links' primitive geometry; one small sphere on each foot point."]
    if draft.mesh_links:
        lines.append(f"# No spheres for mesh-only links (add them by hand): {', '.join(draft.mesh_links)}")
    lines.append("collision_spheres:")
    lines += [f"  - {{link: {s.link}, offset: {_vector(s.offset)}, radius: {s.radius:.4f}}}"
              for s in draft.spheres]
    lines += ["", "# Nominal stance: level base, feet on z = 0 (solved by least squares).", "nominal:",
              f"  base_height: {draft.base_height:.5f}", "  joints:"]
    lines += [f"    {leg}: {_vector(values)}" for leg, values in draft.joints.items()]
    return "\n".join(lines) + "\n"


def write_draft(urdf: str | Path, folder: str | Path, name: str | None = None,
                overwrite: bool = False) -> Path:
    """Draft robot.yaml for `urdf` into `folder` (created), naming the URDF by its path relative to
    the folder (absolute when they share no folder but the root). The draft is loaded
    (`read_spec`) before it is published, so a written draft always loads. Returns its path."""
    from legplan.artefacts.publish import staged_output
    from legplan.artefacts.writer import check_output
    from legplan.robots.spec import read_spec

    folder = Path(folder)
    target = check_output(folder / "robot.yaml", overwrite)
    urdf_abs, folder_abs = Path(urdf).resolve(), folder.resolve()
    related = os.path.commonpath([urdf_abs, folder_abs]) != os.path.sep
    urdf_ref = os.path.relpath(urdf_abs, folder_abs) if related else str(urdf_abs)
    draft = draft_robot(urdf, name or folder.resolve().name)
    folder.mkdir(parents=True, exist_ok=True)
    with staged_output(target, overwrite=overwrite) as temp:
        Path(temp).write_text(draft_yaml(draft, urdf_ref))
        read_spec(temp)
    return target
