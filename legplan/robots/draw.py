"""A picture of a robot in one configuration: 3D view, side view (x-z) and top view (x-y).

Legs are drawn as polylines through their joint origins to the foot; collision spheres as circles
(body grey, legs coloured per leg, foot spheres black); joint directions as magenta arrows along
each joint's axis at its origin (3D and top views): a positive angle turns about the arrow by the
right-hand rule. matplotlib `Figure` (no pyplot state).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pinocchio as pin

from legplan.artefacts.publish import save_figure


def leg_polylines(robot, q) -> list[np.ndarray]:
    """Per leg (k+1, 3): the base origin's hip, each joint origin and the foot, in the world."""
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, np.asarray(q, float))
    lines = []
    for leg in robot.legs:
        points = [data.oMi[model.getJointId(name)].translation for name in leg.joint_names]
        points.append(data.oMf[leg.foot_frame_id].translation)
        lines.append(np.array(points))
    return lines


AXIS_COLOUR = "magenta"


def joint_axes(robot, q) -> tuple[np.ndarray, np.ndarray]:
    """(origins, axes), each (n_joints, 3) in the world: every actuated joint's origin and the unit
    direction a positive joint velocity turns (revolute) or moves (prismatic) about / along."""
    model, data = robot.model, robot.model.createData()
    q = np.asarray(q, float)
    pin.computeJointJacobians(model, data, q)
    origins, axes = [], []
    for joint in range(2, model.njoints):
        jacobian = pin.getJointJacobian(model, data, joint, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        column = jacobian[:, model.idx_vs[joint]]
        angular, linear = column[3:], column[:3]
        axis = angular if np.linalg.norm(angular) > 1e-9 else linear
        origins.append(data.oMi[joint].translation.copy())
        axes.append(axis / np.linalg.norm(axis))
    return np.array(origins), np.array(axes)


def draw_robot(robot, q, path: str | Path, title: str | None = None, *, overwrite: bool = False) -> Path:
    """Write a PNG of `robot` in configuration q (nq,) to `path`."""
    import matplotlib
    from matplotlib.colors import to_rgba
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle

    q = np.asarray(q, float)
    lines = leg_polylines(robot, q)
    hips = np.array([line[0] for line in lines])
    centre = hips.mean(axis=0)
    order = np.argsort(np.arctan2(hips[:, 1] - centre[1], hips[:, 0] - centre[0]))
    body = hips[np.append(order, order[0])]                  # outline through the first joints
    centres = robot.sphere_centres(q)[0]
    spheres = robot.spheres
    colours = matplotlib.colormaps["tab10"](np.arange(len(robot.legs)) % 10)

    def colour(k):
        if spheres.is_foot[k]:
            return to_rgba("black")
        return to_rgba("grey") if spheres.leg_index[k] < 0 else colours[spheres.leg_index[k]]

    fig = Figure(figsize=(13, 4.5))
    ax3 = fig.add_subplot(1, 3, 1, projection="3d")
    for k, line in enumerate(lines):
        ax3.plot(*line.T, "-o", color=colours[k], ms=3, label=robot.legs[k].name)
    ax3.plot(*body.T, color="grey")
    ax3.scatter(*centres.T, s=4, c=[colour(k) for k in range(len(centres))])
    origins, axes = joint_axes(robot, q)
    arrow = 0.3 * robot.leg_length
    ax3.quiver(*origins.T, *(arrow * axes).T, color=AXIS_COLOUR, lw=1.2, arrow_length_ratio=0.3,
               label="joint axes (+: right-hand rule)")
    everything = np.vstack([centres, *lines])
    span = np.ptp(everything, axis=0).max() / 2 + 0.02
    mid = (everything.max(axis=0) + everything.min(axis=0)) / 2
    ax3.set(xlim=(mid[0] - span, mid[0] + span), ylim=(mid[1] - span, mid[1] + span),
            zlim=(mid[2] - span, mid[2] + span), xlabel="x [m]", ylabel="y [m]", zlabel="z [m]")
    ax3.legend(fontsize=7, loc="upper left")
    for index, (a, b, name) in enumerate([(0, 2, "side (x-z)"), (0, 1, "top (x-y)")]):
        ax = fig.add_subplot(1, 3, 2 + index)
        for k in range(len(centres)):
            ax.add_patch(Circle((centres[k, a], centres[k, b]), spheres.radii[k], fill=False,
                                color=colour(k), lw=0.8))
        for k, line in enumerate(lines):
            ax.plot(line[:, a], line[:, b], "-o", color=colours[k], ms=3)
        ax.plot(body[:, a], body[:, b], color="grey", lw=1)
        if b == 1:
            ax.quiver(origins[:, a], origins[:, b], arrow * axes[:, a], arrow * axes[:, b], color=AXIS_COLOUR,
                      angles="xy", scale_units="xy", scale=1, width=0.004)
        if b == 2:
            ax.axhline(0.0, color="saddlebrown", lw=1)
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set(title=name, xlabel="xyz"[a] + " [m]", ylabel="xyz"[b] + " [m]")
    fig.suptitle(title or f"{robot.name}: {robot.n_legs} legs, {robot.nv} DOF, {len(spheres)} spheres")
    fig.tight_layout()
    path = Path(path)
    save_figure(fig, path, overwrite=overwrite, dpi=110)
    return path
