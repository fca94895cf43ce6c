"""The robot's links in the report's 3D view, placed by pinocchio forward kinematics.

Two layers, both from the URDF:

* the skeleton: per leg, the polyline through its joint origins to the foot frame
  (`legplan.robots.draw.leg_polylines`), drawn for every robot, so a shank's line can be seen
  against the terrain even when the URDF has no geometry;
* the shapes: every link's geometry (collision, else visual; `legplan.robots.urdf.read_urdf_links`)
  as a small polyhedron in its link frame: a box as its 8 corners, a cylinder as an 8-sided prism,
  a mesh as its bounding box in the link frame, a sphere as its centre and radius. The shapes are
  sent once; each frame sends the placement of every link that has one.

Scene fields (lengths in integer mm, `legplan.report.scene`): `links` = {"legs": points per leg,
"line": skeleton colour, "shapes": [{"k": link index, "v": vertices (mm, link frame), "f": faces (vertex indices) | "r":
sphere radius (mm)}], "colours": per link}; per frame `k` = skeleton points (sum of legs' points * 3)
and `l` = per link translation (mm) and unit quaternion (x, y, z, w) times 10000.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
import pinocchio as pin

from legplan.report.scene import LEG_COLOURS, mm

BOX_FACES = [[0, 1, 3, 2], [4, 5, 7, 6], [0, 1, 5, 4], [2, 3, 7, 6], [0, 2, 6, 4], [1, 3, 7, 5]]
CYLINDER_SIDES = 8
QUATERNION_SCALE = 10000
BASE_COLOUR = "#8a8f99"
SKELETON_COLOUR = "#2b1d8f"   # the legs' lines; the report test looks for it in a screenshot


def _box(size, placement: pin.SE3) -> tuple[np.ndarray, list]:
    half = np.asarray(size, float) / 2
    corners = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)]) * half
    return corners @ placement.rotation.T + placement.translation, BOX_FACES


def _cylinder(radius: float, length: float, placement: pin.SE3) -> tuple[np.ndarray, list]:
    angles = np.linspace(0, 2 * np.pi, CYLINDER_SIDES, endpoint=False)
    rim = np.stack([radius * np.cos(angles), radius * np.sin(angles), np.zeros(CYLINDER_SIDES)], axis=1)
    local = np.vstack([rim + [0, 0, length / 2], rim - [0, 0, length / 2]])
    n = CYLINDER_SIDES
    faces = [[k, (k + 1) % n, n + (k + 1) % n, n + k] for k in range(n)] + [list(range(n)), list(range(n, 2 * n))]
    return local @ placement.rotation.T + placement.translation, faces


def _shape(shape) -> dict:
    """One URDF shape as vertices (m, link frame) and faces, or a sphere's centre and radius."""
    if getattr(shape, "kind", None) == "sphere":
        return {"v": shape.placement.translation, "r": shape.size[0]}
    if getattr(shape, "kind", None) == "cylinder":
        vertices, faces = _cylinder(*shape.size, shape.placement)
    elif getattr(shape, "kind", None) == "box":
        vertices, faces = _box(shape.size, shape.placement)
    else:  # a mesh: its bounding box in the link frame
        box = shape.bounding_box()
        vertices, faces = _box(box.size, box.placement)
    return {"v": vertices, "f": faces}


@lru_cache(maxsize=8)
def _link_shapes(robot) -> tuple[tuple[int, ...], tuple[dict, ...], tuple[str, ...]]:
    """(frame ids of the links with geometry, their shapes, a colour per link: the leg's or grey)."""
    from legplan.robots.urdf import read_urdf_links

    model = robot.model
    links = read_urdf_links(robot.urdf_path)
    leg_of_joint = {model.getJointId(name): leg for leg, spec in enumerate(robot.legs) for name in spec.joint_names}
    frames, shapes, colours = [], [], []
    for name in links.primitives:
        found = links.shapes(name)
        if not found or not model.existFrame(name):
            continue
        frame = model.getFrameId(name)
        for shape in found:
            shapes.append({"k": len(frames), **_shape(shape)})
        leg = _leg_of(model, model.frames[frame].parentJoint, leg_of_joint)
        colours.append(BASE_COLOUR if leg is None else LEG_COLOURS[leg % len(LEG_COLOURS)])
        frames.append(frame)
    return tuple(frames), tuple(shapes), tuple(colours)


def _leg_of(model, joint: int, leg_of_joint: dict) -> int | None:
    """The leg whose joint moves `joint`'s body (walking up the tree); None for the base."""
    while joint > 0:
        if joint in leg_of_joint:
            return leg_of_joint[joint]
        joint = model.parents[joint]
    return None


def links_static(robot) -> dict:
    """The scene's `links` entry (module docstring) of `robot`."""
    frames, shapes, colours = _link_shapes(robot)
    legs = [len(leg.joint_names) + 1 for leg in robot.legs]
    out = []
    for shape in shapes:
        entry = {"k": shape["k"], "v": mm(shape["v"])}
        entry.update({"r": round(float(shape["r"]) * 1000)} if "r" in shape else {"f": shape["f"]})
        out.append(entry)
    return {"legs": legs, "shapes": out, "colours": list(colours), "line": SKELETON_COLOUR}


def links_frames(robot, Q: np.ndarray) -> list[dict]:
    """Per configuration of Q (n, nq): {"k": skeleton points, "l": link placements} (module docstring)."""
    from legplan.robots.draw import leg_polylines

    frames, _, _ = _link_shapes(robot)
    model, data = robot.model, robot.model.createData()
    out = []
    for q in np.asarray(Q, float):
        skeleton = np.concatenate(leg_polylines(robot, q))  # runs the frame FK on its own data
        pin.framesForwardKinematics(model, data, q)
        placements = []
        for frame in frames:
            placement = data.oMf[frame]
            quat = pin.Quaternion(placement.rotation).coeffs()  # x, y, z, w
            placements += mm(placement.translation) + np.rint(quat * QUATERNION_SCALE).astype(int).tolist()
        out.append({"k": mm(skeleton), "l": placements})
    return out
