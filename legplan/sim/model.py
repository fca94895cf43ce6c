"""The MuJoCo model of a robot folder on a terrain map: `build_model(robot, terrain_map, friction, options)`.

Import path: MuJoCo's own URDF parser (`mujoco.MjSpec.from_string`) reads the robot's URDF (bodies,
masses, inertias, joint axes, mechanical ranges, `<dynamics>` damping and friction loss), after
`legplan.sim.urdf_text.prepare_urdf` has made a typical ROS URDF acceptable to it (visual geometry
dropped, the URDF's collision geometry dropped unless asked for, `package://` meshes resolved,
unphysical inertias repaired with a warning, Drake's rotor inertia read as armature). We do not
convert pinocchio's model to MJCF by hand: the URDF parser is MuJoCo's maintained path and keeps
every inertial as written. The editable `MjSpec` then gets what a URDF cannot say, all from the
robot folder, the map and `ModelOptions` — nothing per robot:

- a free joint on the root link (the URDF's floating base);
- one torque motor per actuated joint (gear 1), its control range the joint's torque limit
  (`legplan.robots.joint_efforts`: robot.yaml's `centroidal.torque_limits`, else the URDF `effort`,
  the limits the planner and the independent check hold the plan to), or an `ModelOptions.effort`
  override (a placeholder such as Solo12's 1000 N m replaced by the real motor's); MuJoCo's URDF parser also puts that limit on the joint
  (`actfrcrange`), which is kept equal to the motor's. A joint with no positive effort and no
  override cannot be driven: `LegplanError`;
- the joints' velocity limits (URDF `velocity`, or a `ModelOptions.velocity` override): MuJoCo has
  none, so they are enforced by the motors (`legplan.sim.run`) and the controller;
  a non-positive or missing limit is not enforced (a warning);
- the joints' armature (`prepare_urdf`), in MuJoCo and in the controller's model alike;
- contact policy: `robot.yaml`'s collision spheres are contact geoms (`contype` 1, `conaffinity`
  0: they touch the terrain, not each other). Foot spheres are the planned contacts; any other
  sphere touching the terrain is an unplanned contact (shin, thigh or trunk). The URDF's own
  collision geometry makes contact only with `ModelOptions.urdf_collision` (meshes MuJoCo does not
  decode, e.g. Collada, loaded by coal; with the terrain
  only, counted as unplanned; on the root link or a link fixed to it, as the trunk's);
- the heightmap of `map.h5` as an `hfield` (one vertex per cell centre, so MuJoCo's surface is the
  bilinear interpolation of the map between cell centres, as the planner's `TerrainModel`), with a
  base 0.5 m thick below its lowest point;
- friction μ (the plan's) on the terrain and the robot's geoms, elliptic (Coulomb) cone, `condim`
  3, and `impratio` 10 so that MuJoCo's soft friction lets a loaded foot creep little.

Physics step `PHYSICS_DT` (0.5 ms, 5 steps per 400 Hz control period, as the paper's controller
rate, Sec. III-B); contacts with a 5 ms time constant (stiffer than MuJoCo's 20 ms default, so a
stance foot sinks about 1 mm under ANYmal's weight) and an impedance of 0.99 to 0.999 (MuJoCo's
default 0.9 to 0.95 lets 5 to 10 % of a constraint go unenforced). Whatever MuJoCo refuses to
compile is a `LegplanError` naming the URDF: a robot it cannot simulate is bad input.
"""

from __future__ import annotations

import fnmatch
from dataclasses import dataclass
from pathlib import Path

import mujoco
import numpy as np
import pinocchio as pin

from legplan.errors import LegplanError
from legplan.parameters import Parameters, param
from legplan.robots import joint_efforts
from legplan.sim.urdf_text import prepare_urdf

PHYSICS_DT = 0.0005            # s
CONTACT_SOLREF = (0.005, 1.0)  # time constant (s), damping ratio
CONTACT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)   # impedance: 99 to 99.9 % of the constraint is enforced
IMPRATIO = 10.0                # friction constraints 10x harder than normal ones (little creep)
HFIELD_BASE = 0.5              # m, thickness of the hfield box below the map's lowest point
HFIELD_MIN_SPAN = 1e-3         # m, elevation range of a flat map's hfield (MuJoCo needs > 0)
MUJOCO_MESHES = (".stl", ".obj", ".msh")   # mesh files MuJoCo decodes itself


@dataclass(frozen=True)
class ModelOptions(Parameters):
    """How the robot's URDF becomes the simulated robot (module docstring). `effort` and `velocity`
    are overrides (joint-name glob pattern, value): the last pattern matching a joint wins."""

    what = "simulation model"

    urdf_collision: bool = False          # the URDF's collision geometry touches the terrain too
    package_paths: tuple = ()             # folders searched first for `package://` (then ROS_PACKAGE_PATH)
    effort: tuple = ()                    # ((pattern, N m), ...) joint torque limit overrides
    velocity: tuple = ()                  # ((pattern, rad/s), ...) joint velocity limit overrides
    effort_scale: float = param(1.0, "(0, inf)", doc="× every effort limit (a what-if: which limits a plan needs)")


@dataclass
class SimModel:
    """A compiled MuJoCo model and how it maps onto the pinocchio robot.

    `model` (mujoco.MjModel); `foot_geoms` (n_legs,) geom ids of the foot spheres in leg order;
    `foot_radius` (n_legs,) m; `body_geoms` geom ids of the other robot geoms (spheres, and the
    URDF's collision geometry when enabled), `trunk_geoms` those of them on the root link or links
    fixed to it; `terrain_geom`; `root_body` (the URDF's root link); per joint in `robot.joint_names`
    order: `effort` (N m, the motors' limits), `velocity_limit` (rad/s, inf: none), `damping`
    (N m s/rad), `armature` (kg m²); `friction` μ; `warnings` (one line each: what was repaired or
    is not enforced).
    Pinocchio and MuJoCo order the URDF's joints differently: `qpos_index`, `dof_index` (n_joints,)
    are MuJoCo's qpos / qvel addresses of `robot.joint_names`; the motors are in pinocchio's order
    (`data.ctrl` = pinocchio's joint torques)."""

    model: mujoco.MjModel
    foot_geoms: np.ndarray
    foot_radius: np.ndarray
    body_geoms: np.ndarray
    trunk_geoms: np.ndarray
    terrain_geom: int
    root_body: int
    effort: np.ndarray
    velocity_limit: np.ndarray
    damping: np.ndarray
    armature: np.ndarray
    friction: float
    qpos_index: np.ndarray
    dof_index: np.ndarray
    warnings: tuple = ()


def _sphere_body(robot, bodies, k):
    """The MuJoCo body holding collision sphere k and the sphere's centre in it: the sphere's frame
    if it is a URDF link, else (a frame robot.yaml added, a fixed joint's frame) the nearest link
    above it in pinocchio's frame tree, which moves with the same joint."""
    spheres, model = robot.spheres, robot.model
    frame = model.frames[int(spheres.frame_ids[k])]
    centre = frame.placement.act(np.asarray(spheres.offsets[k], float))   # in the frame's joint
    link = frame
    while not (link.type == pin.FrameType.BODY and link.name in bodies):
        if link.parentFrame == 0 or link.parentJoint != frame.parentJoint:
            raise LegplanError(f"{robot.yaml_path}: collision sphere frame {frame.name!r} is on no URDF link")
        link = model.frames[link.parentFrame]
    return bodies[link.name], link.placement.actInv(centre)


def _load_meshes(spec, urdf_path) -> None:
    """Meshes in formats MuJoCo does not decode (it reads STL, OBJ and MSH; ROS URDFs often name
    Collada files) loaded by coal's mesh loader (assimp, as pinocchio's geometry models do) and
    handed to MuJoCo as vertices and triangles; the URDF's scale stays on the MuJoCo mesh."""
    import coal

    for mesh in spec.meshes:
        if Path(mesh.file).suffix.lower() in MUJOCO_MESHES:
            continue
        try:
            loaded = coal.MeshLoader().load(mesh.file, np.ones(3))
        except Exception as exc:  # coal raises its own error types for unreadable files
            raise LegplanError(f"{urdf_path}: collision mesh {mesh.file}: cannot be read ({exc})") from None
        triangles = np.array([[loaded.tri_indices(i)[k] for k in range(3)] for i in range(loaded.num_tris)], int)
        mesh.file = ""
        mesh.uservert = np.asarray(loaded.vertices(), float).ravel().tolist()
        mesh.userface = triangles.ravel().tolist()


def joint_overrides(joint_names, values, overrides, option: str) -> np.ndarray:
    """`values` (per joint) with the (pattern, value) `overrides` applied in order; a pattern that
    matches no joint is a `LegplanError` naming `option` and the joints."""
    out = np.array(values, float)
    for pattern, value in overrides:
        hits = [i for i, name in enumerate(joint_names) if fnmatch.fnmatchcase(name, pattern)]
        if not hits:
            raise LegplanError(f"{option} {pattern}={value:g}: the pattern matches no joint "
                               f"(joints: {', '.join(joint_names)})")
        out[hits] = value
    return out


def joint_limits(robot, options: ModelOptions) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Effort (N m) and velocity (rad/s, inf: not enforced) limits per joint with `options`'
    overrides, and the warnings (module docstring)."""
    names = robot.joint_names
    effort = options.effort_scale * joint_overrides(names, joint_efforts(robot), options.effort, "--effort")
    for name, limit in zip(names, effort):
        if not limit > 0:
            raise LegplanError(f"{robot.urdf_path}: joint {name}: effort limit {limit:g} N m cannot drive it; "
                               "give one with --effort JOINT=N·m")
    velocity = joint_overrides(names, robot.model.velocityLimit[6:], options.velocity, "--velocity")
    loose = [name for name, limit in zip(names, velocity) if not (0 < limit < np.inf)]
    velocity[[n in loose for n in names]] = np.inf
    warnings = [f"{robot.urdf_path}: joint(s) {', '.join(loose)} without a positive velocity limit: none "
                "enforced (give one with --velocity JOINT=RAD/S)"] if loose else []
    return effort, velocity, warnings


def build_model(robot, terrain_map, friction: float, options: ModelOptions = ModelOptions()) -> SimModel:
    """The MuJoCo model of `robot` (a `legplan.robots.RobotModel`) on `terrain_map` with friction μ
    (module docstring); `LegplanError` for what cannot be simulated."""
    prepared = prepare_urdf(robot.urdf_path, options.urdf_collision, options.package_paths)
    effort, velocity, warnings = joint_limits(robot, options)
    try:
        spec = mujoco.MjSpec.from_string(prepared.text)
    except ValueError as exc:
        raise LegplanError(f"{robot.urdf_path}: MuJoCo cannot read it ({' '.join(str(exc).split())})") from None
    _load_meshes(spec, robot.urdf_path)
    spec.option.timestep = PHYSICS_DT
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO
    root = spec.worldbody.first_body()
    root.add_freejoint()
    urdf_geoms = [geom.name for geom in spec.geoms]
    for k, geom in enumerate(spec.geoms):   # the URDF's collision geometry, when kept: terrain only
        geom.name = geom.name or f"urdf_geom{k}"
        urdf_geoms[k] = geom.name
        geom.contype, geom.conaffinity, geom.condim = 1, 0, 3
        geom.friction = [friction, 0.005, 0.0001]
        geom.solref, geom.solimp = CONTACT_SOLREF, CONTACT_SOLIMP

    for name, limit in zip(robot.joint_names, effort):
        spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                          ctrllimited=True, ctrlrange=[-limit, limit])
        joint = spec.joint(name)
        joint.actfrcrange = [-limit, limit]   # the parser set it to the URDF effort; keep one limit
        joint.armature = prepared.armature.get(name, 0.0)

    bodies = {body.name: body for body in spec.bodies}
    spheres = robot.spheres
    names = []
    for k in range(len(spheres)):
        frame = spheres.frame_names[k]
        body, centre = _sphere_body(robot, bodies, k)
        name = f"sphere{k}_{frame}"
        body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[spheres.radii[k], 0, 0],
                      pos=centre, contype=1, conaffinity=0, condim=3,
                      friction=[friction, 0.005, 0.0001], solref=CONTACT_SOLREF, solimp=CONTACT_SOLIMP,
                      mass=0, density=0, group=1)
        names.append(name)
    _add_terrain(spec, terrain_map, friction)

    try:
        model = spec.compile()
    except ValueError as exc:
        raise LegplanError(f"{robot.urdf_path}: MuJoCo cannot compile it ({' '.join(str(exc).split())})") from None
    joints = [model.joint(name) for name in robot.joint_names]
    geom_ids = np.array([model.geom(name).id for name in names])
    urdf_ids = np.array([model.geom(name).id for name in urdf_geoms], int)
    foot_frames = [leg.foot_frame for leg in robot.legs]
    feet = []
    for frame in foot_frames:
        k = [i for i in range(len(spheres)) if spheres.is_foot[i] and spheres.frame_names[i] == frame]
        if len(k) != 1:
            raise LegplanError(f"{robot.yaml_path}: foot frame {frame} needs exactly one foot collision sphere")
        feet.append(k[0])
    root_id = model.body(root.name).id   # the trunk: the root link and the links welded to it
    trunk = [g for g in np.concatenate([geom_ids, urdf_ids]) if model.body_weldid[model.geom_bodyid[g]] == root_id]
    dofs = np.array([int(j.dofadr[0]) for j in joints])
    return SimModel(model=model, foot_geoms=geom_ids[feet], foot_radius=np.asarray(spheres.radii)[feet],
                    body_geoms=np.concatenate([np.delete(geom_ids, feet), urdf_ids]).astype(int),
                    trunk_geoms=np.array(trunk, int), terrain_geom=model.geom("terrain").id,
                    root_body=root_id, effort=effort, velocity_limit=velocity, damping=model.dof_damping[dofs].copy(),
                    armature=model.dof_armature[dofs].copy(), friction=float(friction),
                    qpos_index=np.array([int(j.qposadr[0]) for j in joints]), dof_index=dofs,
                    warnings=(*prepared.warnings, *warnings))


def _add_terrain(spec, terrain_map, friction: float) -> None:
    """The heightmap as an hfield geom: vertex (row iy, column ix) at the map's cell centre
    (x0 + r ix, y0 + r iy); MuJoCo's rows run along +y like the map's."""
    height = np.asarray(terrain_map.height, float)
    grid = terrain_map.grid
    ny, nx = height.shape
    if nx < 2 or ny < 2:
        raise LegplanError(f"map {terrain_map.name!r}: a height field needs at least 2 x 2 cells")
    low = float(height.min())
    span = max(float(height.max()) - low, HFIELD_MIN_SPAN)
    half_x, half_y = 0.5 * (nx - 1) * grid.resolution, 0.5 * (ny - 1) * grid.resolution
    spec.add_hfield(name="terrain", size=[half_x, half_y, span, HFIELD_BASE], nrow=ny, ncol=nx,
                    userdata=((height - low) / span).ravel().tolist())
    spec.worldbody.add_geom(name="terrain", type=mujoco.mjtGeom.mjGEOM_HFIELD, hfieldname="terrain",
                            pos=[grid.origin[0] + half_x, grid.origin[1] + half_y, low],
                            contype=0, conaffinity=1, condim=3, friction=[friction, 0.005, 0.0001],
                            solref=CONTACT_SOLREF, solimp=CONTACT_SOLIMP)
