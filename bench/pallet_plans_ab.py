"""One-shot plans of the pushed-pallet bench's tasks in two source trees, compared: what a change of the
planner does to the plans `bench/replan_tasks.py` executes.

    OMP_NUM_THREADS=1 .venv/bin/python bench/pallet_plans_ab.py --before /tmp/ref_tree --after . [--tasks 30]
                                                                [--result NAME]

* Tasks: the first --tasks of `tasks/single_pallet_walk.yaml` drawn with --seed by the library's sampler
  (`legplan.learn.dataset.dataset_items`), planned with `DynParams()`, the heuristic initializer and the
  planner's model (`legplan.dyn.tasks.centroidal_model`), as `bench/replan_tasks.py` plans them.
* Each tree plans in its own child process (PYTHONPATH=the tree, one thread); every plan is judged by
  the independent check (`legplan.validate.trajectory.check_trajectory`).
* Per task: success, LM iterations of all stages, check passed, a sha256 of every variable's values
  (identical bit for bit or not) and the largest change of a foot node's position between the trees.

Writes bench/results/<NAME>.json (default pallet_plans_ab).
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import hashlib  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from common import ROOT, code_version, load_average, machine, write_result  # noqa: E402

SPACE = "tasks/single_pallet_walk.yaml"


def child(tasks: int, seed: int) -> list[dict]:
    """Plan and check the tasks with the `legplan` on sys.path (the tree under test)."""
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynParams
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.learn.dataset import dataset_items, load_terrain_map
    from legplan.learn.space import read_space
    from legplan.robots import load_robot
    from legplan.validate.trajectory import check_trajectory

    space = read_space(ROOT / SPACE)
    terrain_map = load_terrain_map(space)
    terrain = TerrainModel(terrain_map)
    robot = load_robot("anymal")
    params = DynParams()
    model = centroidal_model(robot, params)
    rows = []
    for index, task, _ in dataset_items(space, tasks, seed):
        result = plan(task, model, terrain, params)
        values = result.solve.values
        digest = hashlib.sha256(b"".join(np.ascontiguousarray(values[k], float).tobytes()
                                         for k in sorted(values))).hexdigest()
        check = check_trajectory(result.samples, model, terrain_map, robot, node_times=result.problem.form.knots)
        rows.append({"index": int(index), "success": bool(result.success), "status": result.status.name.lower(),
                     "iterations": int(sum(s.result.iterations for s in result.stages)), "check_ok": bool(check.ok),
                     "digest": digest, "feet": np.asarray(values["feet"], float).reshape(-1, 2, 3)[:, 0].tolist()})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", type=Path, required=True, help="source tree of the reference")
    parser.add_argument("--after", type=Path, default=ROOT, help="source tree of the change")
    parser.add_argument("--tasks", type=int, default=30)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--result", default="pallet_plans_ab")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        json.dump(child(args.tasks, args.seed), sys.stdout)
        return
    load_start = load_average()
    runs = {}
    for label, tree in (("before", args.before), ("after", args.after)):
        env = {**os.environ, "PYTHONPATH": str(Path(tree).resolve())}
        out = subprocess.run([sys.executable, __file__, "--child", "--tasks", str(args.tasks), "--seed", str(args.seed),
                              "--before", str(args.before)], env=env, check=True, capture_output=True, text=True)
        runs[label] = json.loads(out.stdout)
    rows = []
    for a, b in zip(runs["before"], runs["after"]):
        moved = float(np.abs(np.asarray(a["feet"]) - np.asarray(b["feet"])).max())
        rows.append({"index": a["index"], "identical": a["digest"] == b["digest"], "foot_change": moved,
                     **{f"{k}_{label}": r[k] for label, r in (("before", a), ("after", b))
                        for k in ("success", "status", "iterations", "check_ok")}})
    summary = {label: {"success": sum(r["success"] for r in runs[label]), "check_ok": sum(r["check_ok"] for r in runs[label]),
                       "median_iterations": float(np.median([r["iterations"] for r in runs[label]]))}
               for label in runs}
    changes = [r["foot_change"] for r in rows]
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
              "before": str(args.before), "after": str(args.after), "tasks": args.tasks, "seed": args.seed,
              "load_start": load_start, "load_end": load_average(), "summary": summary,
              "identical": sum(r["identical"] for r in rows), "foot_change_median": float(np.median(changes)),
              "foot_change_max": float(np.max(changes)), "rows": rows}
    write_result(args.result, result)
    print(json.dumps({k: result[k] for k in ("summary", "identical", "foot_change_median", "foot_change_max")}))


if __name__ == "__main__":
    main()
