"""`legplan robot check`: what a loaded robot should satisfy beyond robot.yaml's field rules.

Errors (the robot would mislead the planners):
- a foot frame that is not at the distal end of its chain (nearer the leg's first joint than its
  last joint is, in the nominal stance);
- a base height that is not positive, or a base not above every foot;
- a foot off the ground in the nominal stance, or a non-foot collision sphere in the ground;
- no mass: the URDF's links weigh nothing in all (no centre of mass, no dynamics to plan with).
Warnings:
- a foot frame more than `FOOT_FAR_END_TOLERANCE` of the last segment away from the far end of the
  last link's URDF geometry (where `robot init` would put it);
- a non-foot sphere closer to the ground than the size-scaled clearance (2 cm for SCARAB II);
- a link inertia that is not physically consistent: mass <= 0, principal moments not positive or
  breaking the triangle inequality (I1 + I2 >= I3 for every order).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from legplan.errors import LegplanError
from legplan.robots.draft import foot_point
from legplan.robots.sizing import size_scaled
from legplan.robots.spec import FOOT_HEIGHT_TOLERANCE
from legplan.robots.urdf import read_urdf_links

FOOT_FAR_END_TOLERANCE = 0.1   # of the last segment's length
INERTIA_TOLERANCE = 1e-9       # kg m^2, slack of the triangle inequality


@dataclass(frozen=True)
class Finding:
    severity: str   # "error" | "warning"
    subject: str    # leg, sphere, link or "nominal"
    message: str

    def __str__(self) -> str:
        return f"{self.subject}: {self.message}"


def check_robot(robot) -> list[Finding]:
    """Every finding of the checks above for a loaded `RobotModel`, errors first."""
    links = read_urdf_links(robot.urdf_path)
    findings = _feet(robot, links) + _stance(robot) + _inertias(links)
    return sorted(findings, key=lambda f: f.severity != "error")


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
            link, offset = foot_point(model, links, joints[-1], robot.urdf_path)
        except LegplanError:   # no primitive geometry on the last link: nothing to compare with
            continue
        far_end = model.frames[model.getFrameId(link)].placement.act(offset)
        local_foot = model.frames[leg.foot_frame_id].placement.translation
        segment = np.linalg.norm(local_foot)
        gap = float(np.linalg.norm(far_end - local_foot))
        if gap > FOOT_FAR_END_TOLERANCE * max(segment, 1e-9):
            findings.append(Finding("warning", f"leg {leg.name}", f"foot frame '{leg.foot_frame}' is "
                                    f"{gap * 1e3:.1f} mm from the far end of link '{link}''s geometry"))
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
    findings = []
    for name, inertial in links.inertials.items():
        if inertial is None:
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
    return findings


def _moments(moments) -> str:
    return "(" + ", ".join(f"{m:.3g}" for m in moments) + ")"
