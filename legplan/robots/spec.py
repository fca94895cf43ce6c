"""`robot.yaml`: its schema, and its validation against the pinocchio model built from the URDF.

A robot folder holds `robot.urdf` (kinematics, masses, mechanical joint limits) and `robot.yaml`:

```yaml
name: scarab2
urdf: robot.urdf                   # optional, relative to the yaml file
legs:                              # every actuated joint belongs to exactly one leg chain
  - {name: lf, joints: [coxa_lf, femur_lf, tibia_lf], foot_frame: foot_lf}
  - {name: rf, joints: [coxa_rf, femur_rf, tibia_rf],  # or a foot point on a link: frame "rf_foot"
     foot: {link: tibia_rf, offset: [0.12, 0, 0]}}   #   added to the model (URDF untouched)
joint_limits:                      # optional planning limits [lower, upper] inside the URDF limits;
  coxa_lf: [-0.4, 0.4]             # "{leg}" in a key is expanded for every leg
collision_spheres:                 # centre = frame placement * offset; "{leg}" expanded per leg
  - {link: base_link, offset: [0.06, 0.045, 0.0], radius: 0.06}
  - {link: "foot_{leg}", offset: [0, 0, 0], radius: 0.008}   # foot: true|false (default: frame is the foot frame)
nominal:                           # standing configuration, feet on z = 0 (checked to 1 mm)
  base_height: 0.1019
  joints: [0.0, -0.2, 0.0]         # one leg chain applied to every leg, or {leg name: [...]}
navigation:                        # optional, for 2D navigation planners
  footprint: [[x, y], ...]         # base-frame polygon (m), origin inside
  inscribed_radius: 0.2            # optional, checked against the footprint when given
  circumscribed_radius: 0.403
  limits: {v_x_max: .., v_x_min: .., v_y_max: .., omega_max: .., a_x_max: .., a_y_max: .., alpha_max: ..}
centroidal:                        # optional, for centroidal planners: see legplan.robots.centroidal
  mass: 29.5
  ...
```

Every error is a one-line `SpecError` naming the file and the field. docs/robots.md documents
every field with a worked example.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pinocchio as pin

from legplan.parameters import LENGTH
from legplan.robots.centroidal import Centroidal, parse_centroidal
from legplan.robots.navigation import Navigation, parse_navigation
from legplan.robots.urdf_model import UrdfParseError, build_free_flyer_model
from legplan.specio import FieldReader, read_yaml_mapping

FOOT_HEIGHT_TOLERANCE = 1e-3  # m, |z| of every foot in the nominal stance


@dataclass(frozen=True)
class Leg:
    """One leg chain. `joint_idx_q`/`joint_idx_v` index the full q (nq,) / v (nv,) vectors;
    `joint_idx` indexes the actuated-joint arrays (`robot.joint_names`, `lower`, `upper`, the
    joint part of x)."""

    name: str
    joint_names: tuple[str, ...]
    joint_idx_q: tuple[int, ...]
    joint_idx_v: tuple[int, ...]
    joint_idx: tuple[int, ...]
    foot_frame: str
    foot_frame_id: int


@dataclass(frozen=True)
class SphereSet:
    """Collision spheres (paper Fig. 2b): centre = oMf[frame_ids[k]] * offsets[k].

    `leg_index[k]` is the leg whose joints move sphere k (-1: body); `is_foot[k]` marks foot-tip
    spheres (their terrain clearance is relaxed near footholds, paper Sec. II-B)."""

    frame_ids: np.ndarray
    frame_names: tuple[str, ...]
    offsets: np.ndarray
    radii: np.ndarray
    leg_index: np.ndarray
    is_foot: np.ndarray

    def __len__(self) -> int:
        return len(self.radii)


@dataclass(frozen=True)
class RobotSpec:
    """Everything `robot.yaml` + URDF define, validated; `RobotModel` is built from it."""

    name: str
    description: str
    yaml_path: Path
    urdf_path: Path
    model: pin.Model
    legs: tuple[Leg, ...]
    lower: np.ndarray
    upper: np.ndarray
    spheres: SphereSet
    q_nominal: np.ndarray
    navigation: Navigation | None
    centroidal: Centroidal | None


def _build_model(reader: FieldReader, data: dict) -> tuple[Path, pin.Model]:
    urdf = reader.path.parent / reader.get(data, "urdf", "urdf", str, "robot.urdf")
    if not urdf.is_file():
        reader.fail("urdf", f"names a missing file {urdf}")
    try:
        model = build_free_flyer_model(urdf)
    except UrdfParseError as exc:
        reader.fail("urdf", f"cannot be parsed by pinocchio ({exc})")
    for jid in range(2, model.njoints):
        if model.nqs[jid] != 1 or model.nvs[jid] != 1:
            reader.fail("urdf", f"joint '{model.names[jid]}' has nq={model.nqs[jid]}, nv={model.nvs[jid]}; "
                        "only 1-DoF revolute/prismatic joints are supported")
    return urdf, model


def _parse_legs(reader: FieldReader, data: dict, model: pin.Model) -> tuple[Leg, ...]:
    entries = reader.get(data, "legs", "legs", list)
    if not entries:
        reader.fail("legs", "must list at least one leg")
    legs, seen_joints, seen_names = [], {}, set()
    for i, entry in enumerate(entries):
        field = f"legs[{i}]"
        name = reader.get(entry, "name", f"{field}.name", str)
        if name in seen_names:
            reader.fail(f"{field}.name", f"repeats leg name '{name}'")
        seen_names.add(name)
        joints = reader.get(entry, "joints", f"{field}.joints", list)
        if not joints:
            reader.fail(f"{field}.joints", "must list at least one joint")
        ids = []
        for k, joint in enumerate(joints):
            if not isinstance(joint, str) or not model.existJointName(joint):
                reader.fail(f"{field}.joints[{k}]", f"names unknown joint {joint!r} (not in the URDF)")
            if joint in seen_joints:
                reader.fail(f"{field}.joints[{k}]", f"joint '{joint}' already belongs to leg "
                            f"'{seen_joints[joint]}'")
            seen_joints[joint] = name
            jid = model.getJointId(joint)
            parent = ids[-1] if ids else 1
            if model.parents[jid] != parent:
                reader.fail(f"{field}.joints[{k}]", f"joint '{joint}' is not a child of "
                            f"'{model.names[parent]}' (a leg is a chain from the base)")
            ids.append(jid)
        if ("foot" in entry) == ("foot_frame" in entry):
            reader.fail(f"{field}.foot", "give either foot_frame (a frame of the URDF) or foot "
                        "({link, offset}), exactly one")
        if "foot" in entry:
            foot, foot_id, foot_field = _add_foot_frame(reader, entry["foot"], f"{field}.foot", name, model)
        else:
            foot = reader.get(entry, "foot_frame", f"{field}.foot_frame", str)
            foot_id, foot_field = _frame_id(model, foot), f"{field}.foot_frame"
            if foot_id is None:
                reader.fail(foot_field, f"names unknown frame '{foot}'")
        if model.frames[foot_id].parentJoint != ids[-1]:
            reader.fail(foot_field, f"frame '{foot}' is not attached to the last leg joint '{joints[-1]}'")
        legs.append(Leg(name=name, joint_names=tuple(joints),
                        joint_idx_q=tuple(int(model.idx_qs[j]) for j in ids),
                        joint_idx_v=tuple(int(model.idx_vs[j]) for j in ids),
                        joint_idx=tuple(int(model.idx_vs[j]) - 6 for j in ids),
                        foot_frame=foot, foot_frame_id=int(foot_id)))
    n_actuated = model.njoints - 2
    if len(seen_joints) != n_actuated:
        missing = [model.names[j] for j in range(2, model.njoints) if model.names[j] not in seen_joints]
        reader.fail("legs", f"cover {len(seen_joints)} joints but the URDF has {n_actuated} actuated "
                    f"joints (not in any leg: {', '.join(missing)})")
    return tuple(legs)


def _add_foot_frame(reader: FieldReader, foot, field: str, leg: str, model: pin.Model) -> tuple[str, int, str]:
    """Add the foot frame `{link, offset[, frame]}` to the model: an OP_FRAME on the link's parent
    joint at the link frame placement * offset, named `frame` (default "<leg>_foot"); the URDF stays
    untouched. Returns (frame name, frame id, field of the link)."""
    if not isinstance(foot, dict):
        reader.fail(field, "must be a mapping {link: LINK, offset: [x, y, z]}")
    link = reader.get(foot, "link", f"{field}.link", str)
    if not model.existFrame(link, pin.FrameType.BODY):
        reader.fail(f"{field}.link", f"names unknown link '{link}' (not in the URDF)")
    offset = reader.vector(reader.get(foot, "offset", f"{field}.offset", default=[0, 0, 0]), f"{field}.offset", 3)
    name = reader.get(foot, "frame", f"{field}.frame", str, f"{leg}_foot")
    if model.existFrame(name):
        reader.fail(f"{field}.frame", f"frame '{name}' exists already (choose another name)")
    return name, add_foot_frame(model, link, offset, name), f"{field}.link"


def add_foot_frame(model: pin.Model, link: str, offset, name: str) -> int:
    """Add an OP_FRAME `name` at `offset` (m) in the URDF link `link`'s frame: on the link's parent
    joint, placement = link frame placement * offset. Returns its frame id."""
    link_id = model.getFrameId(link, pin.FrameType.BODY)
    parent = model.frames[link_id]
    placement = parent.placement * pin.SE3(np.eye(3), np.asarray(offset, float))
    return int(model.addFrame(pin.Frame(name, parent.parentJoint, link_id, placement, pin.FrameType.OP_FRAME)))


def _frame_id(model: pin.Model, name: str) -> int | None:
    """Id of the frame `name`: the link (BODY) frame when a joint shares its name; None if unknown."""
    if model.existFrame(name, pin.FrameType.BODY):
        return int(model.getFrameId(name, pin.FrameType.BODY))
    if model.existFrame(name):
        try:
            return int(model.getFrameId(name))
        except ValueError:
            return None
    return None


def _expand(key: str, legs) -> list[str]:
    """Expand "{leg}" in a name for every leg."""
    if "{leg}" not in key:
        return [key]
    return [key.replace("{leg}", leg.name) for leg in legs]


def _parse_limits(reader: FieldReader, data: dict, model: pin.Model, legs):
    lower = np.array(model.lowerPositionLimit[7:], float)
    upper = np.array(model.upperPositionLimit[7:], float)
    limits = reader.get(data, "joint_limits", "joint_limits", dict, {})
    for key, value in limits.items():
        field = f"joint_limits.{key}"
        names = _expand(str(key), legs)
        pair = reader.vector(value, field, 2)
        if pair[0] >= pair[1]:
            reader.fail(field, f"lower {pair[0]} must be < upper {pair[1]}")
        for name in names:
            if not model.existJointName(name):
                reader.fail(field, f"names unknown joint '{name}'")
            k = int(model.idx_vs[model.getJointId(name)]) - 6
            if pair[0] < lower[k] - 1e-12 or pair[1] > upper[k] + 1e-12:
                reader.fail(field, f"[{pair[0]}, {pair[1]}] of joint '{name}' is outside the URDF limits "
                            f"[{lower[k]}, {upper[k]}]")
            lower[k], upper[k] = pair
    return lower, upper


def _parse_spheres(reader: FieldReader, data: dict, model: pin.Model, legs) -> SphereSet:
    entries = reader.get(data, "collision_spheres", "collision_spheres", list)
    if not entries:
        reader.fail("collision_spheres", "must list at least one sphere")
    leg_of_joint = {jid: i for i, leg in enumerate(legs)
                    for jid in (model.getJointId(n) for n in leg.joint_names)}
    foot_frames = {leg.foot_frame_id for leg in legs}
    frame_ids, names, offsets, radii, leg_index, is_foot = [], [], [], [], [], []
    for i, entry in enumerate(entries):
        field = f"collision_spheres[{i}]"
        link = reader.get(entry, "link", f"{field}.link", str)
        offset = reader.vector(reader.get(entry, "offset", f"{field}.offset", default=[0, 0, 0]),
                               f"{field}.offset", 3)
        radius = reader.positive(reader.get(entry, "radius", f"{field}.radius"), f"{field}.radius", LENGTH)
        foot_flag = reader.get(entry, "foot", f"{field}.foot", bool, None)
        for name in _expand(link, legs):
            fid = _frame_id(model, name)
            if fid is None:
                reader.fail(f"{field}.link", f"names unknown link/frame '{name}'")
            frame = model.frames[fid]
            frame_ids.append(fid)
            names.append(name)
            offsets.append(offset)
            radii.append(radius)
            # The leg whose joints move the frame: the nearest leg joint among its supports.
            leg = next((leg_of_joint[j] for j in reversed(list(model.supports[frame.parentJoint]))
                        if j in leg_of_joint), -1)
            leg_index.append(leg)
            is_foot.append(fid in foot_frames if foot_flag is None else foot_flag)
    return SphereSet(frame_ids=_frozen(np.array(frame_ids, int)), frame_names=tuple(names),
                     offsets=_frozen(np.array(offsets, float).reshape(-1, 3)),
                     radii=_frozen(np.array(radii, float)),
                     leg_index=_frozen(np.array(leg_index, int)),
                     is_foot=_frozen(np.array(is_foot, bool)))


def _frozen(array: np.ndarray) -> np.ndarray:
    array.setflags(write=False)
    return array


def _parse_nominal(reader: FieldReader, data: dict, model: pin.Model, legs, lower, upper) -> np.ndarray:
    nominal = reader.get(data, "nominal", "nominal", dict)
    height = reader.number(reader.get(nominal, "base_height", "nominal.base_height"),
                           "nominal.base_height")
    joints = reader.get(nominal, "joints", "nominal.joints")
    q = pin.neutral(model)
    q[2] = height
    for i, leg in enumerate(legs):
        if isinstance(joints, dict):
            field = f"nominal.joints.{leg.name}"
            values = reader.vector(reader.get(joints, leg.name, field), field, len(leg.joint_names))
        else:
            field = "nominal.joints"
            values = reader.vector(joints, field, len(leg.joint_names))
        q[list(leg.joint_idx_q)] = values
    inside = (q[7:] >= lower - 1e-9) & (q[7:] <= upper + 1e-9)
    if not inside.all():
        k = int(np.flatnonzero(~inside)[0])
        reader.fail("nominal.joints", f"angle {q[7 + k]:.4f} of joint '{model.names[k + 2]}' is outside "
                    f"its limits [{lower[k]:.4f}, {upper[k]:.4f}]")
    data_ = model.createData()
    pin.framesForwardKinematics(model, data_, q)
    feet_z = np.array([data_.oMf[leg.foot_frame_id].translation[2] for leg in legs])
    worst = int(np.argmax(np.abs(feet_z)))
    if abs(feet_z[worst]) > FOOT_HEIGHT_TOLERANCE:
        reader.fail("nominal.base_height", f"puts foot '{legs[worst].foot_frame}' at z = {feet_z[worst]:.4f} m, "
                    f"not on the ground z = 0 (base_height {height - feet_z.mean():.4f} would)")
    return _frozen(q)


def _check_centroidal(reader: FieldReader, model: pin.Model, q_nominal: np.ndarray, legs, centroidal) -> None:
    """The first field of the centroidal section that contradicts the URDF at the nominal stance
    (`legplan.robots.rigid_body.urdf_contradictions`), as a `SpecError`."""
    from legplan.robots.rigid_body import urdf_contradictions

    found = urdf_contradictions(model, q_nominal, [leg.foot_frame_id for leg in legs], centroidal, legs)
    if found:
        reader.fail(*found[0])


def read_spec(yaml_path: str | Path, strict: bool = True) -> RobotSpec:
    """Read and validate `robot.yaml` (and the URDF it names); raises `SpecError` on any problem.
    `strict=False` skips holding the centroidal section against the URDF (com_offset, inertia,
    nominal feet), for `robot check`, which reports every such field."""
    path = Path(yaml_path)
    reader = FieldReader(path)
    data = read_yaml_mapping(path, "robot spec")
    name = reader.get(data, "name", "name", str, path.parent.name)
    description = reader.get(data, "description", "description", str, "")
    urdf, model = _build_model(reader, data)
    legs = _parse_legs(reader, data, model)
    lower, upper = _parse_limits(reader, data, model, legs)
    spheres = _parse_spheres(reader, data, model, legs)
    q_nominal = _parse_nominal(reader, data, model, legs, lower, upper)
    navigation = parse_navigation(reader, data)
    centroidal = parse_centroidal(reader, data, tuple(leg.name for leg in legs), pin.computeTotalMass(model))
    for leg, limits in zip(legs, getattr(centroidal, "torque_limits", None) or ()):
        if len(limits) != len(leg.joint_names):
            reader.fail(f"centroidal.torque_limits.{leg.name}", f"lists {len(limits)} bounds for the "
                        f"{len(leg.joint_names)} joints of leg {leg.name} ({', '.join(leg.joint_names)})")
    if centroidal is not None and strict:
        _check_centroidal(reader, model, q_nominal, legs, centroidal)
    return RobotSpec(name=name, description=description.strip(), yaml_path=path, urdf_path=urdf,
                     model=model, legs=legs, lower=_frozen(lower), upper=_frozen(upper),
                     spheres=spheres, q_nominal=q_nominal, navigation=navigation, centroidal=centroidal)
