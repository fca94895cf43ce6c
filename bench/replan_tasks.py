"""Held-out single-pallet tasks, each with a random lateral push, executed open loop and closed loop
(`dyn simulate --replan`), issue 39 item 3's target: executed ≥ 95 % with replanning, open loop
reported beside it.

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan_tasks.py [--tasks 100] [--first 0] [--seed 0] [--period 0.25]
                                                             [--model planner|scalar]
                                                             [--param KEY=VALUE ...] [--result NAME]

* Tasks: the first --tasks of `tasks/single_pallet_walk.yaml` drawn with `--seed` by the library's
  sampler (`legplan.learn.dataset.dataset_items`), the tasks `bench/pallet_tasks.py` runs; planned
  with `DynParams()` and the heuristic initializer, on the planner's model (`--model planner`,
  `legplan.dyn.tasks.centroidal_model`, as `legplan dyn plan` and `dyn simulate --replan`) or TOWR's
  scalar model (`--model scalar`, `robot.centroidal`).
* Push per task, from `numpy.random.default_rng(seed + 1000 + index)`: a horizontal force on the
  trunk for `PUSH_DURATION` from a uniform time in [0.25, 0.75] of the plan, its impulse uniform in
  --impulse (default `IMPULSE`) N s, along ±y (sign uniform).
* Each planned task is executed open loop and closed loop (replanning every --period s; the
  simulation waits for each replan; `--param`: `ReplanParams` fields, e.g. `tube_velocity=0.3`).
  Executed = the goal reached without a fall. Counted over the tasks whose plan succeeded.

Writes bench/results/<NAME>.json (default replan_tasks: a run of a chunk with --first names its own); `bench/replan.py`'s BENCHMARKS.md section cites it.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from common import ROOT, code_version, load_average, machine, write_result  # noqa: E402

PUSH_DURATION = 0.1  # s
IMPULSE = (6.0, 14.0)  # N s: the random push's impulse range (the pallet walk's open loop survives 6, falls at 7)
SPACE = "tasks/single_pallet_walk.yaml"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--tasks", type=int, default=100)
    parser.add_argument("--first", type=int, default=0)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--indices", type=int, nargs="+", default=None,
                        help="run only these task indices (each below --tasks), in this order; default: --first to --tasks")
    parser.add_argument("--loops", nargs="+", choices=("open", "closed"), default=["open", "closed"])
    parser.add_argument("--period", type=float, default=0.25)
    parser.add_argument("--impulse", type=float, nargs=2, default=IMPULSE, metavar=("LOW", "HIGH"),
                        help="N s: the random push's impulse range")
    parser.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                        help="a ReplanParams field (legplan.dyn.replan), e.g. tube_velocity=0.3; repeatable")
    parser.add_argument("--result", default="replan_tasks", help="bench/results/<name>.json")
    parser.add_argument("--model", choices=("planner", "scalar"), default="planner",
                        help="planner: centroidal_model (torque rows), as the CLI; scalar: robot.centroidal")
    args = parser.parse_args()

    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynParams
    from legplan.dyn.replan import Previous, ReplanParams
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.learn.dataset import dataset_items, load_terrain_map
    from legplan.learn.space import read_space
    from legplan.robots import load_robot
    from legplan.sim.replanning import Replanner
    from legplan.sim.run import SimParams, simulate
    from legplan.specio import apply_overrides

    load_start, started = load_average(), time.perf_counter()
    space = read_space(ROOT / SPACE)
    terrain_map = load_terrain_map(space)
    terrain = TerrainModel(terrain_map)
    robot = load_robot("anymal")
    params = DynParams()
    model = centroidal_model(robot, params) if args.model == "planner" else robot.centroidal
    settings = apply_overrides(ReplanParams, dict(item.split("=", 1) for item in args.param), "--param", "replan")
    rows = []
    items = dataset_items(space, args.tasks, args.seed)[args.first:]
    if args.indices is not None:  # in the order given
        chosen = {int(index): (index, task, extra) for index, task, extra in items}
        items = [chosen[i] for i in args.indices if i in chosen]
    for index, task, _ in items:
        index = int(index)
        rng = np.random.default_rng(args.seed + 1000 + index)
        at = float(rng.uniform(0.25, 0.75) * task.duration)
        impulse = float(rng.uniform(*args.impulse))
        force = float(rng.choice([-1.0, 1.0])) * impulse / PUSH_DURATION
        planned = plan(task, model, terrain, params)
        row = {"index": index, "planned": bool(planned.success), "push_at": at, "push_fy": force,
               "impulse": impulse}
        if planned.success:
            sim_params = SimParams(pushes=((at, 0.0, force, PUSH_DURATION),))
            for loop in args.loops:
                replanner = (Replanner(Previous.from_plan(planned), model, terrain, params, args.period, settings)
                             if loop == "closed" else None)
                result = simulate(planned.samples, robot, terrain_map, sim_params, goal=task.goal,
                                  replanner=replanner)
                cpu = np.asarray(result.replans.get("cpu_seconds", []), float)
                row[loop] = {"success": result.success, "reason": result.reason, "replans": int(cpu.size),
                             "replans_converged": int(np.sum(result.replans.get("success", []))),
                             "replans_tube": int(np.sum(np.asarray(result.replans.get("trigger", []), bytes)
                                                        == b"tube")),
                             "replans_time_limit": int(np.sum(np.asarray(result.replans.get("status", []), bytes)
                                                              == b"time_limit")),
                             "extension": float(np.sum(result.replans.get("extension", []))),
                             "replan_cpu": cpu.tolist()}
        rows.append(row)
        print(f"task {index}: push {impulse:.1f} N s at {at:.2f} s; planned {row['planned']}"
              + "".join(f"; {loop} {'ok' if row[loop]['success'] else row[loop]['reason'][:40]}"
                        for loop in ("open", "closed") if loop in row), file=sys.stderr, flush=True)
        summary = summarize(rows)
        write_result(args.result, {
            "date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
            "load_start": load_start, "load_end": load_average(), "wall": time.perf_counter() - started,
            "seed": args.seed, "first": args.first, "indices": args.indices, "loops": args.loops, "model": args.model, "period": args.period, "impulse": list(args.impulse),
            "replan_settings": vars(settings), "push_duration": PUSH_DURATION, "rows": rows, **summary})
    print(summarize(rows))


def summarize(rows: list[dict]) -> dict:
    planned = [r for r in rows if r["planned"]]
    out = {"tasks": len(rows), "planned": len(planned)}
    for loop in ("open", "closed"):
        if all(loop in r for r in planned):
            out[f"executed_{loop}"] = sum(r[loop]["success"] for r in planned)
    return out


if __name__ == "__main__":
    main()
