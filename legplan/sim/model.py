"""The MuJoCo model of a robot folder on a terrain map: `build_model(robot, terrain_map, friction)`.

Import path: MuJoCo's own URDF parser (`mujoco.MjSpec.from_string`) reads `robots/<name>/robot.urdf`
(bodies, masses, inertias, joint axes and mechanical ranges), then the editable `MjSpec` gets what a
URDF cannot say. We do not convert pinocchio's model to MJCF by hand: the URDF parser is MuJoCo's
maintained path, keeps every inertial as written, and a converter of ours would be a second URDF
reader to keep right. The parser is told `fusestatic="false"` (a `<mujoco><compiler/></mujoco>`
extension inserted into the URDF text) so that the massless fixed-joint foot links stay bodies.
What the spec adds, all from the robot folder and the map — nothing per robot:

- a free joint on the root link (the URDF's floating base);
- one torque motor per actuated joint (gear 1), its control range the URDF `effort` limit, read
  from pinocchio's `effortLimit` (the URDF `<limit effort>`); MuJoCo's URDF parser also puts that
  limit on the joint (`actfrcrange`), which is kept equal to the motor's;
- `robot.yaml`'s collision spheres as contact geoms (`contype` 1, `conaffinity` 0: they touch the
  terrain, not each other). Foot spheres are the planned contacts; any other sphere touching the
  terrain is an unplanned contact (shin, thigh or trunk);
- the heightmap of `map.h5` as an `hfield` (one vertex per cell centre, so MuJoCo's surface is the
  bilinear interpolation of the map between cell centres, as the planner's `TerrainModel`), with a
  base 0.5 m thick below its lowest point;
- friction μ (the plan's) on the terrain and the feet, elliptic (Coulomb) cone, `condim` 3, and
  `impratio` 10 so that MuJoCo's soft friction lets a loaded foot creep little.

Physics step `PHYSICS_DT` (0.5 ms, 5 steps per 400 Hz control period, as the paper's controller
rate, Sec. III-B); contacts with a 5 ms time constant (stiffer than MuJoCo's 20 ms default, so a
stance foot sinks about 1 mm under ANYmal's weight) and an impedance of 0.99 to 0.999 (MuJoCo's
default 0.9 to 0.95 lets 5 to 10 % of a constraint go unenforced).
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np
import pinocchio as pin

from legplan.errors import LegplanError

PHYSICS_DT = 0.0005            # s
CONTACT_SOLREF = (0.005, 1.0)  # time constant (s), damping ratio
CONTACT_SOLIMP = (0.99, 0.999, 0.001, 0.5, 2.0)   # impedance: 99 to 99.9 % of the constraint is enforced
IMPRATIO = 10.0                # friction constraints 10x harder than normal ones (little creep)
HFIELD_BASE = 0.5              # m, thickness of the hfield box below the map's lowest point
HFIELD_MIN_SPAN = 1e-3         # m, elevation range of a flat map's hfield (MuJoCo needs > 0)
COMPILER = '<mujoco><compiler fusestatic="false" discardvisual="true" balanceinertia="false"/></mujoco>'


@dataclass
class SimModel:
    """A compiled MuJoCo model and how it maps onto the pinocchio robot.

    `model` (mujoco.MjModel); `foot_geoms` (n_legs,) geom ids of the foot spheres in leg order;
    `foot_radius` (n_legs,) m; `body_geoms` geom ids of the other robot spheres, `trunk_geoms` those
    of them on the root link (the trunk); `terrain_geom`;
    `effort` (n_joints,) N m, the motors' limits in `robot.joint_names` order; `friction` μ.
    Pinocchio and MuJoCo order the URDF's joints differently: `qpos_index`, `dof_index` (n_joints,)
    are MuJoCo's qpos / qvel addresses of `robot.joint_names`; the motors are in pinocchio's order
    (`data.ctrl` = pinocchio's joint torques)."""

    model: mujoco.MjModel
    foot_geoms: np.ndarray
    foot_radius: np.ndarray
    body_geoms: np.ndarray
    trunk_geoms: np.ndarray
    terrain_geom: int
    effort: np.ndarray
    friction: float
    qpos_index: np.ndarray
    dof_index: np.ndarray


def _sphere_body(robot, bodies, k):
    """The MuJoCo body holding collision sphere k and the sphere's centre in it: the sphere's URDF
    link, or for a frame robot.yaml added (a foot given as `{link, offset}`) the link it sits on."""
    spheres, model = robot.spheres, robot.model
    frame = model.frames[int(spheres.frame_ids[k])]
    if frame.name in bodies:
        return bodies[frame.name], np.asarray(spheres.offsets[k], float)
    link = model.frames[frame.parentFrame]
    if frame.type == pin.FrameType.OP_FRAME and link.name in bodies:
        return bodies[link.name], link.placement.actInv(frame.placement.act(np.asarray(spheres.offsets[k], float)))
    raise LegplanError(f"{robot.yaml_path}: collision sphere frame {frame.name!r} is not a URDF link")


def build_model(robot, terrain_map, friction: float, effort_scale: float = 1.0) -> SimModel:
    """The MuJoCo model of `robot` (a `legplan.robots.RobotModel`) on `terrain_map` with friction μ;
    `effort_scale` multiplies the URDF effort limits (1: as the URDF says)."""
    xml = robot.urdf_path.read_text()
    head = xml.find(">", xml.find("<robot")) + 1
    if head <= 0:
        raise LegplanError(f"{robot.urdf_path}: no <robot> element")
    spec = mujoco.MjSpec.from_string(xml[:head] + COMPILER + xml[head:])
    spec.option.timestep = PHYSICS_DT
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = IMPRATIO
    root = spec.worldbody.first_body()
    root.add_freejoint()

    effort = effort_scale * np.asarray(robot.model.effortLimit[6:], float)
    for name, limit in zip(robot.joint_names, effort):
        if not limit > 0:
            raise LegplanError(f"{robot.urdf_path}: joint {name} has no positive effort limit")
        spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT,
                          ctrllimited=True, ctrlrange=[-limit, limit])
        spec.joint(name).actfrcrange = [-limit, limit]   # the parser set it to the URDF effort; keep one limit

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

    model = spec.compile()
    joints = [model.joint(name) for name in robot.joint_names]
    geom_ids = np.array([model.geom(name).id for name in names])
    foot_frames = [leg.foot_frame for leg in robot.legs]
    feet = []
    for frame in foot_frames:
        k = [i for i in range(len(spheres)) if spheres.is_foot[i] and spheres.frame_names[i] == frame]
        if len(k) != 1:
            raise LegplanError(f"{robot.yaml_path}: foot frame {frame} needs exactly one foot collision sphere")
        feet.append(k[0])
    return SimModel(model=model, foot_geoms=geom_ids[feet], foot_radius=np.asarray(spheres.radii)[feet],
                    body_geoms=np.delete(geom_ids, feet),
                    trunk_geoms=geom_ids[[k for k in range(len(spheres)) if spheres.frame_names[k] == root.name]],
                    terrain_geom=model.geom("terrain").id,
                    effort=effort, friction=float(friction),
                    qpos_index=np.array([int(j.qposadr[0]) for j in joints]),
                    dof_index=np.array([int(j.dofadr[0]) for j in joints]))


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
