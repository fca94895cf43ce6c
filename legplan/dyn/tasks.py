"""The tasks of `legplan dyn plan`: from the command line or a tasks file, each checked before any work.

A tasks file holds one task per row (CSV: a header row; YAML: a list `tasks:` of mappings, or a bare
list), with the fields

    start_x, start_y, start_yaw, goal_x, goal_y, goal_yaw     base x, y (m) and yaw (rad), required
    gait, strides, duration                                    optional: walk|trot, >= 1, > 0 s

where the optional fields default to the command's `--gait`, `--strides`, `--duration`. The
command-line task is the same fields from `--start`, `--goal`, ... (checked as the row of a file
"command line"). Every rule lives here, for both forms; a failure is a one-line `SpecError` naming
the file, the row (0-based) and the field:

* numbers finite and in their physical ranges (`RANGES`: coordinates, yaws, the duration); `strides`
  a whole number >= 1 (`legplan.budget` bounds what the strides and duration make); `gait` one of
  `GAITS`; no unknown field;
* start and goal placeable (`placement_problem`): the base and its nominal feet (the centroidal
  model's `nominal_feet` rotated by the yaw) inside the heightmap, and not in a wall: the terrain
  under the base and those feet may span at most the nominal base height (`Centroidal.base_height`,
  0.42 m for ANYmal). A larger span puts the base or a foot inside a wall or pillar (e.g. the base
  over a pillar between its feet): no stance there has its feet on the terrain and the base above it.
"""

from __future__ import annotations

import os
from dataclasses import replace
from pathlib import Path

import numpy as np

from legplan.budget import check_size
from legplan.dyn.gait import GAITS, make_gait
from legplan.dyn.legs import ChainLegs
from legplan.dyn.problem import DynTask
from legplan.dyn.terrain import TerrainModel
from legplan.errors import LegplanError, SpecError
from legplan.parameters import COORDINATE, DURATION, YAW
from legplan.robots.rigid_body import torque_limits
from legplan.specio import FieldReader, read_csv_table, read_yaml

POSE_FIELDS = ("start_x", "start_y", "start_yaw", "goal_x", "goal_y", "goal_yaw")
OPTIONAL_FIELDS = ("gait", "strides", "duration")
FIELDS = POSE_FIELDS + OPTIONAL_FIELDS
COMMAND_LINE = "command line"
RANGES = {**{f"{end}_{axis}": COORDINATE for end in ("start", "goal") for axis in ("x", "y")},
          "start_yaw": YAW, "goal_yaw": YAW, "duration": DURATION}
"""The physical range of every numeric field (`legplan.parameters`' quantities; `--start`, `--goal`
and `--duration` take the same)."""


def task_from_fields(reader: FieldReader, fields: dict, defaults: DynTask = DynTask((0, 0, 0), (0, 0, 0))) -> DynTask:
    """The `DynTask` of one row of fields (missing optional fields from `defaults`), every field checked."""
    reader.unknown(fields, FIELDS)
    start, goal = ([reader.number(reader.get(fields, f"{end}_{axis}", f"{end}_{axis}"), f"{end}_{axis}",
                                  RANGES[f"{end}_{axis}"]) for axis in ("x", "y", "yaw")] for end in ("start", "goal"))
    gait = reader.choice(reader.get(fields, "gait", "gait", default=defaults.gait), "gait", GAITS)
    strides = reader.count(reader.get(fields, "strides", "strides", default=defaults.strides), "strides")
    duration = reader.number(reader.get(fields, "duration", "duration", default=defaults.duration), "duration",
                             RANGES["duration"])
    return replace(defaults, start=tuple(start), goal=tuple(goal), gait=gait, strides=strides, duration=duration)


def command_line_task(start, goal, gait, strides, duration) -> DynTask:
    """The task of `--start X Y YAW --goal X Y YAW [--gait] [--strides] [--duration]` (None = default)."""
    fields = dict(zip(POSE_FIELDS, (*start, *goal)))
    fields.update({k: v for k, v in zip(OPTIONAL_FIELDS, (gait, strides, duration)) if v is not None})
    return task_from_fields(FieldReader(COMMAND_LINE), fields)


def read_tasks(path: str | os.PathLike, gait=None, strides=None, duration=None) -> list[DynTask]:
    """The tasks of a CSV or YAML tasks file; `gait`, `strides`, `duration` (None: `DynTask`'s) are
    the defaults of rows without them."""
    path = Path(path)
    given = {k: v for k, v in zip(OPTIONAL_FIELDS, (gait, strides, duration)) if v is not None}
    defaults = task_from_fields(FieldReader(COMMAND_LINE), {**dict.fromkeys(POSE_FIELDS, 0.0), **given})
    suffix = path.suffix.lower()
    if suffix == ".csv":
        rows = _csv_rows(path)
    elif suffix in (".yaml", ".yml"):
        rows = _yaml_rows(path)
    else:
        raise SpecError(f"{path}: unknown tasks file format '{suffix}' (expected .csv, .yaml or .yml)")
    if not rows:
        raise SpecError(f"{path}: no tasks (expected one row per task with fields {', '.join(POSE_FIELDS)})")
    return [task_from_fields(FieldReader(path, f"row {i}"), row, defaults) for i, row in enumerate(rows)]


def _csv_rows(path: Path) -> list[dict]:
    header, table = read_csv_table(path, "tasks file")
    return [{name: _cell(text) for name, text in zip(header, cells) if text.strip()} for cells in table]


def _cell(text: str):
    """A CSV cell as int, float or (stripped) string, so that the fields are checked as typed YAML values."""
    text = text.strip()
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _yaml_rows(path: Path) -> list[dict]:
    data = read_yaml(path, "tasks file")
    if isinstance(data, dict) and "tasks" not in data and {"start", "goal"} <= set(data):
        raise SpecError(f"{path}: is a learn task space (fields 'start' and 'goal' as ranges, read by "
                        f"`legplan learn dataset`), not a tasks file; --tasks takes one task per row with "
                        f"fields {', '.join(POSE_FIELDS)} (or give --start X Y [YAW] --goal X Y [YAW])")
    if isinstance(data, dict):
        FieldReader(path).unknown(data, ("tasks",))
        data = data.get("tasks")
    if not isinstance(data, list):
        raise SpecError(f"{path}: field 'tasks' must be a list of mappings, one per task")
    for i, row in enumerate(data):
        if not isinstance(row, dict):
            raise SpecError(f"{path}: row {i}: must be a mapping of {', '.join(FIELDS)}")
    return data


def placement_problem(pose, model, terrain: TerrainModel, map_name: str = "the map") -> str | None:
    """Why the base pose (x, y, yaw) cannot stand on `terrain` (module docstring's rule), or None."""
    x, y, yaw = pose
    rz = np.array([[np.cos(yaw), -np.sin(yaw)], [np.sin(yaw), np.cos(yaw)]])
    points = np.vstack([[x, y], np.array([x, y]) + model.nominal_feet[:, :2] @ rz.T])
    names = ("base", *(f"foot {leg}" for leg in model.legs))
    inside = terrain.contains(points)
    if not inside.all():
        lo = terrain.origin
        hi = terrain.origin + terrain.resolution * (np.array(terrain.shape[::-1]) - 1)
        k = int(np.flatnonzero(~inside)[0])
        return (f"puts the {names[k]} at ({points[k, 0]:.3f}, {points[k, 1]:.3f}) off {map_name} "
                f"(x in [{lo[0]:.3f}, {hi[0]:.3f}], y in [{lo[1]:.3f}, {hi[1]:.3f}] m)")
    heights = terrain.height(points[:, 0], points[:, 1])
    span = float(heights.max() - heights.min())
    if span > model.base_height:
        high = int(np.argmax(heights))
        return (f"is in a wall of {map_name}: the terrain under the base and feet spans {span:.3f} m (the "
                f"{names[high]} at {heights[high]:.3f} m), more than the nominal base height {model.base_height:.3f} m")
    return None


def check_placements(tasks: list[DynTask], model, terrain: TerrainModel, source: str | os.PathLike | None,
                     map_path: str | os.PathLike) -> None:
    """`SpecError` for the first task whose start or goal fails `placement_problem` on map `map_path`;
    `source` is the tasks file, or None for the command line."""
    for i, task in enumerate(tasks):
        for end, pose in (("start", task.start), ("goal", task.goal)):
            problem = placement_problem(pose, model, terrain, f"the map {map_path}")
            if problem is not None:
                where = f"{source}: row {i}" if source is not None else COMMAND_LINE
                raise SpecError(f"{where}: field '{end}' ({', '.join(f'{v:g}' for v in pose)}) {problem}")


def check_sizes(tasks: list[DynTask], params, source: str | os.PathLike | None, rows: bool = True) -> None:
    """Before anything is built: a `legplan.budget.SizeError` for the first task whose problem would
    exceed the variable budget (the paper's N = 12T/dt + 20S + 120, Sec. III-A, with S at most 4
    footsteps a stride), and a `SpecError` for one whose duration cannot hold its feet's phases of at
    least `phase_min` when `params` (`DynParams`) optimizes them. `source` is the tasks file (rows
    named unless `rows` is false: a task space's one template), None for the command line."""
    for i, task in enumerate(tasks):
        where = COMMAND_LINE if source is None else f"{source}: row {i}" if rows else str(source)
        nodes, steps = 12 * task.duration / params.dt, 20 * 4 * task.strides
        check_size("variables", nodes + steps + 120, f"{where}: field '{'strides' if steps > nodes else 'duration'}'")
        if params.optimize_phases:
            gait = make_gait(task.gait, task.strides, task.duration)
            phases = max(len(gait.foot_phases(leg)) for leg in range(gait.stance.shape[1]))
            if phases * params.phase_min > task.duration:
                raise SpecError(f"{where}: field 'duration' {task.duration:g} s is too short to optimize the "
                                f"phases: a foot has {phases} phases of at least {params.phase_min:g} s "
                                f"(--optimize-phases needs {phases * params.phase_min:g} s)")


def centroidal_model(robot, params=None, costs: str = "--costs"):
    """The `centroidal:` model of a loaded robot with the joint torque limits the robot has
    (`legplan.robots.torque_limits`: robot.yaml's, else the URDF's efforts, so that the planner keeps
    |Jᵀf| inside what the check judges and the simulator's motors give), the legs' chains
    (`Centroidal.leg_chains`, for those limits) and the kinematics its legs' spheres are placed by
    in the planner's leg clearance: the planar closed form (`legplan.robots.planar_legs`, cheaper)
    where the legs have it, else the legs' chains (`legplan.dyn.legs.ChainLegs`, any serial leg); or
    a one-line error naming its robot.yaml; with `params` (`DynParams`) asking for leg clearance, one
    naming the `costs` source when the robot's legs are neither."""
    if robot.centroidal is None:
        raise LegplanError(f"{robot.yaml_path}: field 'centroidal' is missing (the single-rigid-body model "
                           "that `legplan dyn` plans with, see legplan.robots.centroidal)")
    if robot.n_legs != 4:
        raise LegplanError(f"{robot.yaml_path}: field 'legs' lists {robot.n_legs} legs; `legplan dyn` plans "
                           "quadrupeds (four legs: left front, right front, left hind, right hind)")
    chains = ChainLegs.of_robot(robot)
    legs = robot.centroidal.leg_kinematics or chains  # the closed form where it exists
    limits = torque_limits(robot)
    if params is not None and params.leg_clearance is not None and legs is None:
        raise LegplanError(f"{costs}: field 'leg_clearance': {robot.yaml_path}'s legs are not serial chains of "
                           "revolute joints from the base, whose spheres the planner can place (legplan.dyn.legs)")
    if robot.centroidal.torque_limits is not None and chains is None:
        raise LegplanError(f"{robot.yaml_path}: field 'centroidal.torque_limits': the legs are not serial chains of "
                           "revolute joints from the base, whose torques the planner can place (legplan.dyn.legs)")
    return replace(robot.centroidal, leg_kinematics=legs, leg_chains=chains,
                   torque_limits=limits if chains is not None else None)
