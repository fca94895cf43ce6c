"""Which robot an artefact was made for: the robot files' digest (`robot_sha256`, recorded as the
root attribute `robot_sha256`), how an artefact names the robot so later stages load the same one
(`robot_reference`), and the one check where an artefact meets a loaded robot (`check_same_robot`).
"""

from __future__ import annotations

import hashlib
import os

from legplan.errors import ArtefactError, LegplanError


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


def check_same_robot(path: str | os.PathLike, recorded: str, robot, what: str = "made") -> None:
    """An `ArtefactError` when the robot files an artefact was `what` for (their digest `recorded`)
    are not those of the loaded `robot` now (its robot.yaml or URDF changed since)."""
    if recorded and recorded != robot_sha256(robot):
        raise ArtefactError(f"{path}: {what} for another version of robot '{robot.name}' (root attribute "
                            f"'robot_sha256' differs from {robot.yaml_path} and its URDF now); make it again")
