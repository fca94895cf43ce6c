"""Per-task functions of `legplan dyn plan` for `legplan.batch`: a worker context and the task records.

    task = Task(plan_item, failed_item, DynWorker, (robot_name, map_path, params, heuristic))
    items = task_items(tasks)          # (index, DynTask) pairs

Each item is planned (`legplan.dyn.planner.plan`), checked independently on its 10 ms samples
(`legplan.validate.trajectory.check_trajectory`) and returned as the record of `artefact`.
"""

from __future__ import annotations

from legplan.dyn.artefact import failed_record, trajectory_record
from legplan.dyn.problem import DynParams, DynTask


class DynWorker:
    """What one worker loads once: the robot and its centroidal model, the map (as the check reads
    it and as the optimizer's `TerrainModel`), the parameters; `initializer` is the object the command
    resolved (picklable: a module-level function or `legplan.learn.network.LearnedInit`)."""

    def __init__(self, robot_name: str, map_path: str, params: DynParams, initializer):
        from legplan.dyn.tasks import centroidal_model
        from legplan.dyn.terrain import TerrainModel
        from legplan.robots import load_robot
        from legplan.terrain import load_map

        self.robot = load_robot(robot_name)
        self.model = centroidal_model(self.robot, params)
        self.terrain_map = load_map(map_path)
        self.terrain = TerrainModel(self.terrain_map)
        self.params = params
        self.initializer = initializer

    @classmethod
    def of(cls, robot, model, terrain_map, terrain, params: DynParams, initializer) -> DynWorker:
        """A worker holding what the caller has already loaded (what `__init__` would load)."""
        worker = cls.__new__(cls)
        worker.robot, worker.model, worker.terrain_map, worker.terrain = robot, model, terrain_map, terrain
        worker.params, worker.initializer = params, initializer
        return worker

    def plan(self, index: int, task: DynTask) -> dict:
        from legplan.dyn.planner import plan
        from legplan.validate.trajectory import check_trajectory

        result = plan(task, self.model, self.terrain, self.params, self.initializer)
        check = check_trajectory(result.samples, self.model, self.terrain_map, self.robot,
                                 node_times=result.problem.form.knots)
        return trajectory_record(index, task, result, check)


def task_items(tasks: list[DynTask]) -> list[tuple[int, DynTask]]:
    """The batch items: (position, task)."""
    return list(enumerate(tasks))


def plan_item(worker: DynWorker, item: tuple[int, DynTask]) -> dict:
    """Plan one item with a `DynWorker`: the per-item function `legplan.batch.Task` runs."""
    return worker.plan(*item)


def failed_item(item: tuple[int, DynTask], reason: str) -> dict:
    """The record of an item whose planning raised or whose worker died (`legplan.batch.Task`)."""
    return failed_record(*item, reason)
