"""Robot facts a step-sequence file refers to: the URDF joint order and the robot files' hash."""

from __future__ import annotations

import hashlib
import xml.etree.ElementTree as ET

from legplan.errors import LegplanError, SpecError


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


def robot_sha256(robot) -> str:
    """sha256 of robot.yaml followed by robot.urdf: identifies the robot a sequence was made for."""
    digest = hashlib.sha256()
    for path in (robot.yaml_path, robot.urdf_path):
        digest.update(path.read_bytes())
    return digest.hexdigest()


def robot_reference(robot) -> str:
    """How a sequence names its robot so later stages load the same one: the robot's name when that
    name finds this robot.yaml on the search path (`legplan.robots.resolve_robot`), else the absolute
    path of its robot.yaml (a robot folder given by path, e.g. one just drafted by `robot init`)."""
    from legplan.robots import resolve_robot

    try:
        if resolve_robot(robot.name).resolve() == robot.yaml_path.resolve():
            return robot.name
    except LegplanError:
        pass
    return str(robot.yaml_path.resolve())
