"""Task spaces of the learned initializer (Sec. IV-B, IV-C of the TOWR-costs paper): where tasks x come from.

A task-space file (`tasks/*.yaml`) fixes everything that shapes the solution vector y — map, robot,
gait, strides, duration, costs — and gives the ranges the start and goal base poses are sampled from:

    name: single_pallet_walk            # optional, default: the file's stem
    map: ../maps/single_pallet.yaml     # a map spec (built on load) or a map artefact .h5; relative to this file
    robot: anymal                       # optional, default anymal (needs a `centroidal:` section)
    gait: walk                          # walk | trot
    strides: 4                          # walk 4 = 16 footsteps, trot 4 = 14 (the paper's Sec. V)
    duration: 5.5                       # s
    costs: paper                        # optional, default paper: a `dyn plan --costs` preset or costs file
    start: {x: [-1.5, -0.5], y: [-0.75, 0.75], yaw: [-0.5236, 0.5236]}   # m, m, rad: uniform ranges
    goal: {x: 0.6, y: 0.0, yaw: 0.0}                                     # a number = fixed

Tasks are drawn uniformly from the ranges with a seeded `numpy.random.Generator`; a draw whose start
or goal cannot stand on the map (`legplan.dyn.tasks.placement_problem`) is redrawn, so the same seed
gives the same tasks. The task vector x the network sees (`task_vector`) is the start pose in the
goal's frame (dx, dy, dyaw) followed by the goal pose (x, y, yaw) on the map.

Every field is checked on load; a bad one is a one-line `SpecError` naming the file and the field.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from legplan.dyn.gait import GAITS
from legplan.dyn.problem import DynTask
from legplan.dyn.settings import PRESETS
from legplan.errors import SpecError
from legplan.geometry.angles import wrap_angle
from legplan.budget import STRIDES
from legplan.dyn.tasks import RANGES
from legplan.specio import FieldReader, read_yaml_mapping

FIELDS = ("name", "map", "robot", "gait", "strides", "duration", "costs", "start", "goal")
AXES = ("x", "y", "yaw")
X_NAMES = ("start_dx", "start_dy", "start_dyaw", "goal_x", "goal_y", "goal_yaw")
"""Columns of the task vector x (m, m, rad; the start in the goal's frame)."""
MAX_DRAWS = 100  # per task: rejected placements before the space is declared unplaceable


@dataclass(frozen=True)
class TaskSpace:
    """A checked task-space file: fixed problem shape plus (lo, hi) ranges of start and goal x, y, yaw."""

    path: str
    name: str
    map: str
    robot: str
    gait: str
    strides: int
    duration: float
    costs: str
    start: tuple[tuple[float, float], ...]
    goal: tuple[tuple[float, float], ...]

    def record(self) -> dict:
        """The JSON-able identity of the space (what a dataset and an initializer were made for)."""
        from legplan.artefacts import sha256_file

        record = {"name": self.name, "map": self.map, "map_sha256": sha256_file(self.map), "robot": self.robot,
                  "gait": self.gait,
                  "strides": self.strides, "duration": self.duration, "costs": self.costs,
                  "start": [list(r) for r in self.start], "goal": [list(r) for r in self.goal]}
        if self.map.endswith(".h5"):  # a map artefact: its terrain, which a rebuilt map shares
            from legplan.artefacts.identity import terrain_digest

            record["map_terrain"] = terrain_digest(self.map)
        return record

    def task(self, start, goal) -> DynTask:
        return DynTask(start=tuple(map(float, start)), goal=tuple(map(float, goal)), gait=self.gait,
                       strides=self.strides, duration=self.duration)


def read_space(path: str | os.PathLike) -> TaskSpace:
    """The task space of a YAML file (module docstring), every field checked."""
    path = Path(path)
    data = read_yaml_mapping(path, "task-space file")
    reader = FieldReader(path)
    reader.unknown(data, FIELDS)
    name = reader.get(data, "name", "name", str, default=path.stem)
    map_path = path.parent / reader.get(data, "map", "map", str)
    if not map_path.is_file():
        reader.fail("map", f"names '{map_path}', which is not a file")
    if map_path.suffix.lower() not in (".yaml", ".yml", ".h5"):
        reader.fail("map", f"must be a map spec (.yaml) or a map artefact (.h5), got '{map_path.name}'")
    robot = reader.get(data, "robot", "robot", str, default="anymal")
    gait = reader.choice(reader.get(data, "gait", "gait"), "gait", GAITS)
    strides = reader.count(reader.get(data, "strides", "strides"), "strides", STRIDES)
    duration = reader.number(reader.get(data, "duration", "duration"), "duration", RANGES["duration"])
    costs = reader.get(data, "costs", "costs", str, default="paper")
    if costs not in PRESETS:
        costs_path = path.parent / costs
        if not costs_path.is_file():
            reader.fail("costs", f"must be a preset ({', '.join(PRESETS)}) or a costs file, got '{costs}'")
        costs = os.fspath(costs_path)
    ends = {end: tuple(_range(reader, reader.get(data, end, end, dict), end, axis) for axis in AXES)
            for end in ("start", "goal")}
    return TaskSpace(os.fspath(path), name, os.fspath(map_path), robot, gait, strides, duration, costs, **ends)


def _range(reader: FieldReader, ranges: dict, end: str, axis: str) -> tuple[float, float]:
    reader.unknown(ranges, AXES, prefix=f"{end}.")
    field = f"{end}.{axis}"
    value = reader.get(ranges, axis, field)
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        number = reader.number(value, field, RANGES[f"start_{axis}"])
        return number, number
    lo, hi = reader.vector(value, field, 2, RANGES[f"start_{axis}"])
    if lo > hi:
        reader.fail(field, f"must be [low, high] with low <= high, got {value!r}")
    return float(lo), float(hi)


def sample_tasks(space: TaskSpace, n: int, rng: np.random.Generator, model, terrain) -> list[DynTask]:
    """`n` tasks drawn uniformly from the space's ranges, each redrawn until its start and goal can
    stand on `terrain` (`placement_problem`); deterministic for a given generator state."""
    from legplan.dyn.tasks import placement_problem

    lo = np.array([r[0] for r in space.start + space.goal])
    hi = np.array([r[1] for r in space.start + space.goal])
    tasks = []
    for i in range(n):
        for _ in range(MAX_DRAWS):
            pose = rng.uniform(lo, hi)
            problem = next((p for p in (placement_problem(pose[:3], model, terrain),
                                        placement_problem(pose[3:], model, terrain)) if p), None)
            if problem is None:
                tasks.append(space.task(pose[:3], pose[3:]))
                break
        else:
            raise SpecError(f"{space.path}: field 'start' / 'goal': no placeable task in {MAX_DRAWS} draws "
                            f"(task {i}; last draw {problem})")
    return tasks


def task_vector(start, goal) -> np.ndarray:
    """x of a task (`X_NAMES`): the start (x, y, yaw) in the frame of the goal (x, y, yaw), then the goal."""
    start, goal = np.asarray(start, float), np.asarray(goal, float)
    c, s = np.cos(goal[2]), np.sin(goal[2])
    d = start[:2] - goal[:2]
    dyaw = wrap_angle(start[2] - goal[2])
    return np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], dyaw, *goal])


def load_terrain_map(space: TaskSpace):
    """The space's map: built from its spec, or loaded from its artefact."""
    from legplan.terrain import build_map, load_map

    return load_map(space.map) if space.map.endswith(".h5") else build_map(space.map)
