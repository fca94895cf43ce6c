"""Per-task functions of `legplan dyn simulate` for `legplan.batch`: a worker context and the records.

    task = Task(simulate_item, failed_item, SimWorker, (robot_name, map_path, params))
    items = sim_items(traj_tasks)      # (index, planned, samples or None, goal, plan's reason) per traj task

A task whose plan did not succeed (its solver failed or its check did not pass) is not executed:
it is recorded as skipped with the plan's reason, so that a simulated success always belongs to a
plan that passed.
"""

from __future__ import annotations

from legplan.sim.artefact import failed_record, sim_record
from legplan.sim.run import SimParams, simulate


class SimWorker:
    """What one worker loads once: the robot, the map and the simulation parameters."""

    def __init__(self, robot_name: str, map_path: str, params: SimParams, replan=None):
        from legplan.robots import load_robot
        from legplan.terrain import load_map

        self.robot = load_robot(robot_name)
        self.terrain_map = load_map(map_path)
        self.params = params
        self.replan = replan  # (period s, the plan's DynParams[, ReplanParams]) with `dyn simulate --replan`

    def replanner(self, task: dict):
        """The closed loop's `legplan.sim.replanning.Replanner` of a traj task (with `replan`)."""
        from legplan.dyn.replan import Previous, ReplanParams
        from legplan.dyn.tasks import centroidal_model
        from legplan.dyn.terrain import TerrainModel
        from legplan.sim.replanning import Replanner

        period, params, *settings = self.replan
        model = centroidal_model(self.robot, params)
        return Replanner(Previous.from_record(task, model.com_offset, params.dt), model,
                         TerrainModel(self.terrain_map), params, period, *(settings or [ReplanParams()]))


def sim_items(tasks: list[dict]) -> list[tuple]:
    """The batch items of a traj artefact's task groups (`legplan.dyn.artefact.read_tasks`):
    (index, the plan's success, its samples or None when it has none, its goal, the plan's reason,
    the task group: a closed loop replans from its nodes)."""
    return [(int(t["index"]), bool(t["success"]), t.get("samples"), tuple(float(g) for g in t["goal"]),
             str(t["reason"]), t) for t in tasks]


def simulate_item(worker: SimWorker, item: tuple) -> dict:
    """Execute one traj task (`legplan.batch.Task`'s per-item function)."""
    index, planned, samples, goal, plan_reason, task = item
    if not planned:
        return failed_record(index, planned, f"skipped: the plan did not succeed ({plan_reason})", skipped=True)
    if samples is None:
        return failed_record(index, planned, "no trajectory to execute (the plan failed before sampling)")
    replanner = worker.replanner(task) if worker.replan is not None else None
    result = simulate(samples, worker.robot, worker.terrain_map, worker.params, goal=goal, replanner=replanner)
    return sim_record(index, planned, result)


def failed_item(item: tuple, reason: str) -> dict:
    """The record of an item whose simulation raised or whose worker died."""
    return failed_record(item[0], item[1], reason)
