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

    def __init__(self, robot_name: str, map_path: str, params: SimParams):
        from legplan.robots import load_robot
        from legplan.terrain import load_map

        self.robot = load_robot(robot_name)
        self.terrain_map = load_map(map_path)
        self.params = params


def sim_items(tasks: list[dict]) -> list[tuple]:
    """The batch items of a traj artefact's task groups (`legplan.dyn.artefact.read_tasks`):
    (index, the plan's success, its samples or None when it has none, its goal, the plan's reason)."""
    return [(int(t["index"]), bool(t["success"]), t.get("samples"), tuple(float(g) for g in t["goal"]),
             str(t["reason"])) for t in tasks]


def simulate_item(worker: SimWorker, item: tuple) -> dict:
    """Execute one traj task (`legplan.batch.Task`'s per-item function)."""
    index, planned, samples, goal, plan_reason = item
    if not planned:
        return failed_record(index, planned, f"skipped: the plan did not succeed ({plan_reason})", skipped=True)
    if samples is None:
        return failed_record(index, planned, "no trajectory to execute (the plan failed before sampling)")
    result = simulate(samples, worker.robot, worker.terrain_map, worker.params, goal=goal)
    return sim_record(index, planned, result)


def failed_item(item: tuple, reason: str) -> dict:
    """The record of an item whose simulation raised or whose worker died."""
    return failed_record(item[0], item[1], reason)
