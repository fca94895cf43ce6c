"""Lateral push survived open loop vs closed loop (`dyn simulate --replan`), issue 39 item 3, a first
look on a small case: a flat 2-stride walk (3 s, (0, 0, 0) → (0.5, 0.1, 0.1), `DynParams()`), pushed
along +y at half its duration for `DURATION` s with increasing forces; each level executed open loop
and closed loop (replanning every `PERIOD` s). Survived = reached the goal without falling.

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan_push.py

Writes bench/results/replan_push.json (no BENCHMARKS.md section of its own: `bench/replan.py`'s
section cites it).
"""

from __future__ import annotations

import datetime
import time

import numpy as np

from common import code_version, load_average, machine, write_result

FORCES = (50.0, 65.0, 80.0, 100.0)  # N along +y
DURATION = 0.1  # s
PERIOD = 0.25  # s


def main() -> None:
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynParams, DynTask
    from legplan.dyn.replan import Previous
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.sim.replanning import Replanner
    from legplan.sim.run import SimParams, simulate
    from legplan.terrain import Grid2D, terrain_from_heightmap

    load_start = load_average()
    robot = load_robot("anymal")
    params = DynParams()
    model = centroidal_model(robot, params)
    grid = Grid2D(origin=(-1.0, -1.0), resolution=0.02, shape=(101, 151))
    terrain_map = terrain_from_heightmap(np.zeros(grid.shape), grid, name="flat")
    terrain = TerrainModel(terrain_map)
    task = DynTask((0.0, 0.0, 0.0), (0.5, 0.1, 0.1), "walk", 2, 3.0)
    planned = plan(task, model, terrain, params)
    rows = []
    for force in FORCES:
        sim_params = SimParams(pushes=((task.duration / 2, 0.0, force, DURATION),))
        for loop in ("open", "closed"):
            replanner = (Replanner(Previous.from_plan(planned), model, terrain, params, PERIOD)
                         if loop == "closed" else None)
            started = time.perf_counter()
            result = simulate(planned.samples, robot, terrain_map, sim_params, goal=task.goal, replanner=replanner)
            replans = result.replans
            rows.append({"force": force, "impulse": force * DURATION, "loop": loop, "success": result.success,
                         "reason": result.reason, "replans": int(len(replans.get("t", []))),
                         "replans_converged": int(np.sum(replans.get("success", []))),
                         "wall": time.perf_counter() - started})
            print(rows[-1], flush=True)
    best = {loop: max([r["impulse"] for r in rows if r["loop"] == loop and r["success"]], default=0.0)
            for loop in ("open", "closed")}
    write_result("replan_push", {"date": datetime.date.today().isoformat(), "machine": machine(),
                                 "code": code_version(), "load_start": load_start, "load_end": load_average(),
                                 "task": [task.start, task.goal, task.gait, task.strides, task.duration],
                                 "duration": DURATION, "period": PERIOD, "rows": rows,
                                 "largest_survived_impulse": best})
    print("largest survived impulse (N s):", best)


if __name__ == "__main__":
    main()
