"""Finding robots: by name on the robot search path, or by a path to a robot folder or robot.yaml.

The search path is the folders of the environment variable `LEGPLAN_ROBOTS` (separated by ':',
searched in order; empty entries are ignored), then the shipped robots. A robot is a sub-folder
holding `robot.yaml`; the first folder on the path that has a robot of a name wins.

The shipped robots are the repository's top-level `robots/` folder. The package reaches it as the
package data `legplan/robot_models` (a symbolic link to `../robots` in the source tree; a wheel
holds the files themselves), read through `importlib.resources`, so a plain install finds them
without the repository (docs/robots.md, "Installing").
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from typing import TYPE_CHECKING

from legplan.errors import LegplanError, did_you_mean
from legplan.shipped import package_data

if TYPE_CHECKING:
    from legplan.robots.model import RobotModel

SPEC_NAME = "robot.yaml"
ENV_ROBOTS = "LEGPLAN_ROBOTS"


def shipped_robots_dir() -> Path:
    """The folder of the robots that ship with legplan (package data `legplan/robot_models`), with
    the link resolved: the repository's `robots/` in a source checkout, so messages name it."""
    return package_data("robot_models").resolve()


def robot_search_path() -> list[Path]:
    """The folders searched for robots by name, in order: `LEGPLAN_ROBOTS`'s, then the shipped one."""
    extra = [Path(entry) for entry in os.environ.get(ENV_ROBOTS, "").split(os.pathsep) if entry]
    for folder in extra:  # a mistyped entry is bad input, not an empty folder
        if not folder.is_dir():
            raise LegplanError(f"{ENV_ROBOTS}: '{folder}' is not a folder"
                               f"{' (no such path)' if not folder.exists() else ''}")
    return [*extra, shipped_robots_dir()]


@dataclass(frozen=True)
class RobotEntry:
    """A robot folder on the search path: `robot` when it loads, else `problem` says why not."""

    name: str
    folder: Path
    robot: RobotModel | None
    problem: str | None


def _candidate_folders() -> dict[str, Path]:
    """Name -> folder of every sub-folder on the search path that holds a robot.yaml or a URDF
    (first folder on the path wins)."""
    found: dict[str, Path] = {}
    for root in robot_search_path():
        if not root.is_dir():
            continue
        for folder in sorted(root.iterdir()):
            if folder.is_dir() and folder.name not in found and (
                    (folder / SPEC_NAME).is_file() or any(folder.glob("*.urdf"))):
                found[folder.name] = folder
    return found


def survey_robots() -> list[RobotEntry]:
    """Every robot on the search path, loaded; a folder that does not load (no robot.yaml, a bad
    field, a URDF pinocchio rejects) is listed with its reason instead of raising."""
    from legplan.robots.model import RobotModel
    from legplan.robots.spec import read_spec

    entries = []
    for name, folder in sorted(_candidate_folders().items()):
        spec = folder / SPEC_NAME
        if not spec.is_file():
            entries.append(RobotEntry(name, folder, None, _missing_spec(folder)))
            continue
        try:
            entries.append(RobotEntry(name, folder, RobotModel(read_spec(spec)), None))
        except (LegplanError, OSError, RuntimeError, ValueError) as exc:
            entries.append(RobotEntry(name, folder, None, str(exc).splitlines()[0] if str(exc)
                                      else type(exc).__name__))
    return entries


def _missing_spec(folder: Path) -> str:
    return f"{folder / SPEC_NAME}: missing (draft one with `legplan robot init URDF -o {folder}`)"


def list_robots() -> list[str]:
    """Names of the robots on the search path (folders holding a robot.yaml), sorted."""
    return sorted(name for name, folder in _candidate_folders().items() if (folder / SPEC_NAME).is_file())


def resolve_robot(robot: str | os.PathLike) -> Path:
    """The robot.yaml of a robot name, a robot folder or a robot.yaml path."""
    path = Path(robot)
    if path.is_dir():
        path = path / SPEC_NAME
    if path.is_file():
        return path
    if isinstance(robot, str) and os.sep not in robot and not robot.endswith((".yaml", ".yml")):
        candidates = _candidate_folders()
        folder = candidates.get(robot)
        if folder is None:  # names are matched case-insensitively when that leaves one robot
            same = [f for name, f in candidates.items() if name.lower() == robot.lower()]
            folder = same[0] if len(same) == 1 else None
        if folder is not None:
            if not (folder / SPEC_NAME).is_file():
                raise LegplanError(_missing_spec(folder))
            return folder / SPEC_NAME
        searched = os.pathsep.join(str(root) for root in robot_search_path())
        known = ", ".join(list_robots()) or "none"
        hint = did_you_mean(robot, list_robots())
        raise LegplanError(f"{robot}: unknown robot{hint} (searched {searched}; known: {known})")
    raise LegplanError(f"{robot}: no such robot folder or {SPEC_NAME}")


def load_robot(robot: str | os.PathLike, strict: bool = True) -> RobotModel:
    """Load and validate a robot by name ("scarab2"), folder or robot.yaml path (`strict`: see
    `legplan.robots.spec.read_spec`)."""
    from legplan.robots.model import RobotModel  # pinocchio: imported when a robot is loaded
    from legplan.robots.spec import read_spec

    return RobotModel(read_spec(resolve_robot(robot), strict))
