"""Finding robots: by name in the robots folder, or by a path to a robot folder or robot.yaml.

The robots folder is `robots/` next to the `legplan` package (the repository's data folder),
overridable with the environment variable `LEGPLAN_ROBOTS`.
"""

from __future__ import annotations

import os
from pathlib import Path

import legplan
from legplan.errors import LegplanError
from legplan.robots.model import RobotModel
from legplan.robots.spec import read_spec

SPEC_NAME = "robot.yaml"
ENV_ROBOTS = "LEGPLAN_ROBOTS"


def robots_dir() -> Path:
    """The folder holding one sub-folder per robot."""
    override = os.environ.get(ENV_ROBOTS)
    return Path(override) if override else Path(legplan.__file__).resolve().parents[1] / "robots"


def list_robots() -> list[str]:
    """Names of the robots in `robots_dir()` (sub-folders holding a robot.yaml), sorted."""
    root = robots_dir()
    if not root.is_dir():
        return []
    return sorted(p.name for p in root.iterdir() if (p / SPEC_NAME).is_file())


def resolve_robot(robot: str | os.PathLike) -> Path:
    """The robot.yaml of a robot name, a robot folder or a robot.yaml path."""
    path = Path(robot)
    if path.is_dir():
        path = path / SPEC_NAME
    if path.is_file():
        return path
    if isinstance(robot, str) and os.sep not in robot and not robot.endswith((".yaml", ".yml")):
        candidate = robots_dir() / robot / SPEC_NAME
        if candidate.is_file():
            return candidate
        known = ", ".join(list_robots()) or "none"
        raise LegplanError(f"{robot}: unknown robot (known in {robots_dir()}: {known})")
    raise LegplanError(f"{robot}: no such robot folder or {SPEC_NAME}")


def load_robot(robot: str | os.PathLike) -> RobotModel:
    """Load and validate a robot by name ("scarab2"), folder or robot.yaml path."""
    return RobotModel(read_spec(resolve_robot(robot)))
