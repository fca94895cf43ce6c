"""Robot facts a step-sequence file refers to: the URDF joint order and the robot files' hash."""

from __future__ import annotations

import xml.etree.ElementTree as ET

from legplan.errors import SpecError
from legplan.robots.identity import robot_reference, robot_sha256  # noqa: F401 (where sequences name them)


def urdf_joint_order(robot) -> tuple[str, ...]:
    """Actuated joint names in the order the URDF file lists them (files may use it for `joints`)."""
    try:
        root = ET.parse(robot.urdf_path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise SpecError(f"{robot.urdf_path}: cannot read the URDF ({exc})") from None
    actuated = set(robot.joint_names)
    order = tuple(j.get("name") for j in root.iter("joint") if j.get("name") in actuated)
    if len(order) != len(actuated):
        raise SpecError(f"{robot.urdf_path}: URDF joints do not match the model's {len(actuated)} joints")
    return order
