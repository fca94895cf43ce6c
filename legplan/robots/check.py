"""`legplan robot check`: what a loaded robot should satisfy beyond robot.yaml's field rules.

Errors (the robot would mislead the planners):
- a foot frame that is not at the distal end of its chain (nearer the leg's first joint than its
  last joint is, in the nominal stance);
- a base height that is not positive, or a base not above every foot;
- a foot off the ground in the nominal stance, or a non-foot collision sphere in the ground;
- no mass: the URDF's links weigh nothing in all (no centre of mass, no dynamics to plan with).
- centroidal section: a field that contradicts the URDF at the nominal stance (com_offset, inertia,
  nominal_feet: `legplan.robots.rigid_body.urdf_contradictions`, the rule the loader enforces); a
  nominal foot or a corner, edge midpoint or face centre of the range-of-motion box that its leg
  does not reach by IK inside the planning joint limits; four legs not in the order the gaits take them (left front, right front,
  left hind, right hind).
Warnings:
- a foot frame more than `FOOT_FAR_END_TOLERANCE` of the last segment away from where `robot init`
  would put it (`legplan.robots.draft.contact_point`);
- a non-foot sphere closer to the ground than the size-scaled clearance (2 cm for SCARAB II);
- a link inertia that is not physically consistent: mass <= 0, principal moments not positive or
  breaking the triangle inequality (I1 + I2 >= I3 for every order); links lighter than
  `FRAME_LINK_MASS` of the robot (frames, sensors) are not checked, one note lists them;
- efforts that are placeholders (`legplan.robots.rigid_body.leg_forces`): then nothing but
  centroidal.max_normal_force bounds the forces (otherwise the joints' limits bound them through the
  legs, `legplan.robots.torque_limits`; `torque_limits` above the URDF's efforts are errors).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from legplan.errors import LegplanError
from legplan.robots.draft import contact_point, quadruped_order
from legplan.robots.legik import leg_reach
from legplan.robots.rigid_body import box_points, leg_forces, unreachable_points, urdf_contradictions
from legplan.robots.sizing import size_scaled
from legplan.robots.spec import FOOT_HEIGHT_TOLERANCE
from legplan.robots.urdf import read_urdf_links

FOOT_FAR_END_TOLERANCE = 0.1   # of the last segment's length
INERTIA_TOLERANCE = 1e-9       # kg m^2, slack of the triangle inequality
FRAME_LINK_MASS = 1e-3         # of the robot's mass: lighter links are frames, their inertia unchecked
SEVERITIES = ("error", "warning", "note")


@dataclass(frozen=True)
class Finding:
    severity: str   # "error" | "warning" | "note"
    subject: str    # leg, sphere, link, "nominal" or a robot.yaml field ("centroidal.inertia")
    message: str

    def __str__(self) -> str:
        return f"{self.subject}: {self.message}"


def check_robot(robot, package_paths=()) -> list[Finding]:
    """Every finding of the checks above for a loaded `RobotModel`, errors first, then warnings,
    then notes. `package_paths`: where `package://` meshes are looked up first."""
    links = read_urdf_links(robot.urdf_path, package_paths)
    findings = _feet(robot, links) + _stance(robot) + _inertias(links) + _centroidal(robot)
    return sorted(findings, key=lambda f: SEVERITIES.index(f.severity))


def _feet(robot, links) -> list[Finding]:
    model, data = robot.model, robot.model.createData()
    pin.framesForwardKinematics(model, data, robot.q_nominal)
    findings = []
    for leg in robot.legs:
        joints = [model.getJointId(name) for name in leg.joint_names]
        hip, last = data.oMi[joints[0]].translation, data.oMi[joints[-1]].translation
        foot = data.oMf[leg.foot_frame_id].translation
        if np.linalg.norm(foot - hip) <= np.linalg.norm(last - hip):
            findings.append(Finding("error", f"leg {leg.name}", f"foot frame '{leg.foot_frame}' is not at the "
                                    f"distal end of the chain (no farther from joint '{leg.joint_names[0]}' "
                                    f"than joint '{leg.joint_names[-1]}')"))
            continue
        try:
            link, offset = contact_point(model, data, links, joints[-1], robot.urdf_path)
        except LegplanError:   # no geometry and no foot link: nothing to compare with
            continue
        drafted = data.oMf[model.getFrameId(link, pin.FrameType.BODY)].act(offset)
        segment = np.linalg.norm(model.frames[leg.foot_frame_id].placement.translation)
        gap = float(np.linalg.norm(drafted - foot))
        if gap > FOOT_FAR_END_TOLERANCE * max(segment, 1e-9):
            findings.append(Finding("warning", f"leg {leg.name}", f"foot frame '{leg.foot_frame}' is "
                                    f"{gap * 1e3:.1f} mm from where robot init puts the foot (link '{link}''s "
                                    "geometry: a foot link's lowest point, else the far end)"))
    return findings


def _stance(robot) -> list[Finding]:
    q = robot.q_nominal
    findings = []
    feet = robot.foot_positions(q)[0]
    if q[2] <= 0 or np.any(feet[:, 2] >= q[2]):
        findings.append(Finding("error", "nominal", f"base height {q[2]:.4f} m must be positive and above "
                                "every foot"))
    for leg, z in zip(robot.legs, feet[:, 2]):
        if abs(z) > FOOT_HEIGHT_TOLERANCE:
            findings.append(Finding("error", f"leg {leg.name}", f"foot at z = {z:.4f} m in the nominal stance"))
    clearance = size_scaled("clearance", robot.leg_length)
    spheres = robot.spheres
    heights = robot.sphere_centres(q)[0][:, 2] - spheres.radii
    for k in np.flatnonzero(~np.asarray(spheres.is_foot, bool)):
        subject = f"sphere {k} ({spheres.frame_names[k]})"
        if heights[k] < 0:
            findings.append(Finding("error", subject, f"{-heights[k] * 1e3:.1f} mm in the ground in the "
                                    "nominal stance"))
        elif heights[k] < clearance:
            findings.append(Finding("warning", subject, f"{heights[k] * 1e3:.1f} mm above the ground in the "
                                    f"nominal stance, less than the clearance {clearance * 1e3:.1f} mm "
                                    "steps generate keeps"))
    return findings


def _inertias(links) -> list[Finding]:
    total = sum(inertial.mass for inertial in links.inertials.values() if inertial is not None)
    findings, frames = [], []
    for name, inertial in links.inertials.items():
        if inertial is None:
            continue
        if 0 <= inertial.mass < FRAME_LINK_MASS * total:
            frames.append(name)
            continue
        moments = np.linalg.eigvalsh(inertial.inertia)
        if inertial.mass <= 0:
            problem = f"mass {inertial.mass:g} kg is not positive"
        elif moments.min() <= 0:
            problem = f"principal moments {_moments(moments)} kg m^2 are not all positive"
        elif moments[0] + moments[1] < moments[2] - INERTIA_TOLERANCE:
            problem = (f"principal moments {_moments(moments)} kg m^2 break the triangle inequality "
                       f"({moments[0]:.3g} + {moments[1]:.3g} < {moments[2]:.3g})")
        else:
            continue
        findings.append(Finding("warning", f"link {name}", f"inertia is not physically consistent: {problem}"))
    total = sum(max(inertial.mass, 0.0) for inertial in links.inertials.values() if inertial is not None)
    if not total > 0:
        findings.append(Finding("error", "robot", "the URDF's links have no mass in all (total 0 kg): "
                                "no centre of mass or dynamics to plan with"))
    if frames:
        shown = ", ".join(frames[:6]) + (", ..." if len(frames) > 6 else "")
        findings.append(Finding("note", "links", f"{len(frames)} links carry less than {FRAME_LINK_MASS:.1%} of the "
                                f"mass (frames, sensors: {shown}); their inertias are not checked"))
    return findings


def _centroidal(robot) -> list[Finding]:
    c = robot.centroidal
    if c is None:
        return []
    findings = [Finding("error", field, message) for field, message in
                urdf_contradictions(robot.model, robot.q_nominal, [leg.foot_frame_id for leg in robot.legs], c,
                                    robot.legs)]
    reach = leg_reach(robot, np.zeros((1, 3)), np.eye(3)[None], c.nominal_feet[None])
    for k in np.flatnonzero(~reach.reachable[0]):
        findings.append(Finding("error", f"centroidal.nominal_feet.{c.legs[k]}", "is out of the leg's reach inside "
                                f"the joint limits (the IK stops {reach.error[0, k] * 1e3:.1f} mm away)"))
    missed = unreachable_points(robot, c.nominal_feet, c.range_of_motion)
    if missed.any():
        points = box_points(c.range_of_motion)
        legs = [f"{c.legs[k]} ({int(missed[:, k].sum())}/{len(points)}, e.g. {_signed(points[np.argmax(missed[:, k])])})"
                for k in np.flatnonzero(missed.any(axis=0))]
        findings.append(Finding("error", "centroidal.range_of_motion", f"{_signed(c.range_of_motion)} m: box "
                                f"corners, edge midpoints or face centres out of reach inside the joint limits for legs "
                                f"{', '.join(legs)}"))
    forces = leg_forces(robot)
    if forces.placeholder:
        shown = ", ".join(forces.placeholder[:3]) + (", ..." if len(forces.placeholder) > 3 else "")
        findings.append(Finding("warning", "centroidal.max_normal_force", f"{c.max_normal_force:g} N is not backed "
                                f"by the URDF: the efforts of {shown} are placeholders (missing, or a leg would push "
                                f"{forces.force.max():.0f} N, more than 10 robot weights)"))
    if robot.n_legs == 4:
        data = robot.model.createData()
        pin.forwardKinematics(robot.model, data, robot.q_nominal)
        hips = np.array([data.oMi[robot.model.getJointId(leg.joint_names[0])].translation for leg in robot.legs])
        if quadruped_order(hips) != [0, 1, 2, 3]:
            findings.append(Finding("error", "legs", "the centroidal planner's gaits take four legs as left front, "
                                    "right front, left hind, right hind; robot.yaml lists "
                                    f"{', '.join(leg.name for leg in robot.legs)} in another order"))
    return findings


def _moments(moments) -> str:
    return "(" + ", ".join(f"{m:.3g}" for m in moments) + ")"


def _signed(values) -> str:
    return "(" + ", ".join(f"{v:+.3f}" for v in values) + ")"
