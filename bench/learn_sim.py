"""Fig. 8 of the TOWR-costs paper with its simulator: plans after k LM iterations, executed in MuJoCo.

    .venv/bin/python bench/learn_sim.py [--run bench/results/learn] [--space tasks/single_pallet_walk.yaml]
                                        [--tasks 30] [--jobs 2] [--init NAME_OR_H5 --tasks-seed 1]
                                        [--budgets 0,1,2,3,4,5] [--name learn_sim22_flat_trot]

The paper's Fig. 8 counts a plan as a success when its whole-body controller, in simulation, walks
it to the goal; `bench/learn.py` reads Fig. 8 without the simulator (converged, or feasible, within
k iterations). Here, for the first --tasks held-out tasks of a `bench/learn.py` run directory (its
heldout_heuristic.h5: seed 1) and every budget k = 0 … 100 (N_θ = 25, N_h = 100):

1. `plan` with at most k LM iterations in all (`DynParams.iteration_budget`), from the Heuristic and
   from the last cycle's init.h5 (or `--init`: a shipped initializer's name or an init.h5) — warm stage costs with the phase durations fixed at the network's
   timing (the paper's dotted curve) and optimized (solid), and the projection — whatever stage the
   planner stopped in; k = 0 executes the initializer's raw guess (the paper: "executable without
   any further optimization" more than half the time);
2. its 10 ms samples executed by `legplan.sim.simulate` (whole-body controller at 400 Hz, ANYmal at
   its URDF torque limits, μ as planned) with the task's goal: a success when the robot reaches it
   (10 cm, 0.2 rad, after 0.5 s settling) without falling, as the paper's "trials that did not reach
   the goal state were marked as failures".

With `--tasks-seed S` the held-out tasks are drawn from the space by the library's sampler
(`legplan.learn.dataset.dataset_items`, seed S) instead of read from the run's heldout_heuristic.h5,
so a shipped initializer needs no `bench/learn.py` run.

Items run through the batch layer (`--jobs` worker processes). Writes bench/results/learn_sim.json
and the learn_sim section of BENCHMARKS.md (another space than the single pallet walk:
learn_sim_<space name>, its own JSON and section; `--name`: that name for both). `--budgets` picks
the budgets k (default `BUDGETS`); the section also gives, per k, the share of tasks executed at
some budget k' ≤ k (the first plan of the budgets tried that walks, as a replanner that stops at
the first executable plan would keep).
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time
from pathlib import Path

import numpy as np
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result

BUDGETS = (0, 1, 2, 3, 5, 10, 25, 100)  # 25: N_θ; 100: N_h, where the Heuristic converges


class Worker:
    """What a worker loads once: the space's planner model and terrain, the robot and map for the
    simulator, and the initializers by name."""

    def __init__(self, space_path: str):
        from legplan.learn.dataset import DatasetWorker
        from legplan.learn.space import load_terrain_map, read_space
        from legplan.robots import load_robot

        self.space = read_space(space_path)
        planner = DatasetWorker(self.space, "heuristic", None)
        self.model, self.terrain = planner.model, planner.terrain
        self.robot = load_robot(self.space.robot)
        self.terrain_map = load_terrain_map(self.space)
        self.initializers = {}

    def initializer(self, init: str):
        from legplan.learn.initializers import initializer

        if init not in self.initializers:
            self.initializers[init] = initializer(init)
        return self.initializers[init]


def plan_and_execute(worker: Worker, item) -> dict:
    """One item (row, init, warm stage, phases optimized, k, task index, task row): plan, execute."""
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynTask
    from legplan.learn.dataset import solver_params
    from legplan.sim.run import simulate

    row, init, warm_stage, phases, k, index, task_row = item
    space = worker.space
    task = DynTask(tuple(task_row[:3]), tuple(task_row[3:]), space.gait, space.strides, space.duration)
    planned = plan(task, worker.model, worker.terrain, solver_params(space.costs, k, warm_stage, phases),
                   worker.initializer(init))
    executed = simulate(planned.samples, worker.robot, worker.terrain_map, goal=tuple(task_row[3:]))
    return {"row": row, "k": k, "index": index, "success": bool(executed.success), "reason": executed.reason,
            "fell": bool(executed.fell), "converged": bool(planned.success),
            "max_violation": float(planned.solve.max_violation), "iterations": int(planned.solve.iterations),
            "rms_position_error": float(executed.rms_position_error), "saturation": float(executed.saturation),
            "fall_time": float(executed.fall_time), "unplanned_contacts": list(executed.unplanned_contacts)}


def failed(item, reason: str) -> dict:
    row, _, _, _, k, index, _ = item
    return {"row": row, "k": k, "index": index, "success": False, "reason": reason, "fell": False,
            "converged": False, "max_violation": float("nan"), "iterations": 0, "rms_position_error": float("nan"), "saturation": float("nan"),
            "fall_time": float("nan"), "unplanned_contacts": []}


def main() -> None:
    import h5py

    from legplan.batch import Backend, Task

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--run", default="bench/results/learn", help="a bench/learn.py --out directory")
    parser.add_argument("--space", default="tasks/single_pallet_walk.yaml")
    parser.add_argument("--tasks", type=int, default=30)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--init", help="a shipped initializer's name or an init.h5 (default: the run's last cycle)")
    parser.add_argument("--tasks-seed", type=int, help="draw the held-out tasks from the space with this seed")
    parser.add_argument("--budgets", default=",".join(map(str, BUDGETS)), help="comma-separated LM budgets k")
    parser.add_argument("--name", help="result and BENCHMARKS section name (default: learn_sim[_<space>])")
    parser.add_argument("--rows", default="heuristic,fixed,optimized,projection",
                        help="comma-separated rows to run: heuristic, fixed (phases), optimized (phases), projection")
    args = parser.parse_args()
    run_dir = (ROOT / args.run).resolve()
    if args.init:
        last, name = args.init, f"LearnedInit {Path(args.init).stem}"
    else:
        inits = sorted((run_dir / "cycle").glob("init_*.h5"), key=lambda p: int(p.stem.split("_")[1]))
        if not inits:
            sys.exit(f"{run_dir / 'cycle'}: no init_*.h5 (run bench/learn.py --out {args.run} first)")
        last, name = str(inits[-1]), f"LearnedInit cycle {len(inits)}"
    every = {"heuristic": ("Heuristic", "heuristic", "costs", False),
             "fixed": (f"{name}, phases fixed (dotted)", last, "costs", False),
             "optimized": (f"{name}, phases optimized (solid)", last, "costs", True),
             "projection": (f"{name}, projection", last, "projection", False)}
    rows = [every[key] for key in args.rows.split(",")]
    budgets = tuple(sorted({int(k) for k in args.budgets.split(",")}))
    if args.tasks_seed is not None:
        from legplan.learn.dataset import dataset_items
        from legplan.learn.space import read_space

        tasks = np.array([[*task.start, *task.goal] for _, task, _ in dataset_items(read_space(str(ROOT / args.space)), args.tasks,
                                                          args.tasks_seed)])
        source = f"drawn with seed {args.tasks_seed}"
    else:
        with h5py.File(run_dir / "heldout_heuristic.h5", "r") as f:
            tasks = f["tasks"][()][:args.tasks]
        source = f"of the `bench/learn.py` run in `{run_dir.name}` (seed 1)"
    items = [(r, init, stage, phases, k, i, tasks[i]) for r, (_, init, stage, phases) in enumerate(rows)
             for k in budgets for i in range(len(tasks))]
    started, code, t0 = load_average(), code_version(), time.perf_counter()
    executor = Backend(args.jobs).start()
    records = []
    try:
        for count, (_, record) in enumerate(executor.run(Task(plan_and_execute, failed, Worker,
                                                              (str(ROOT / args.space),)), list(enumerate(items))), 1):
            records.append(record)
            if count % 20 == 0 or count == len(items):
                print(f"{count}/{len(items)} executed, {time.perf_counter() - t0:.0f} s", file=sys.stderr, flush=True)
    finally:
        executor.close()
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code,
              "load_average_start": started, "load_average_end": load_average(), "space": args.space,
              "run": str(run_dir), "tasks": len(tasks), "task_source": source, "jobs": args.jobs, "wall_seconds": time.perf_counter() - t0,
              "budgets": list(budgets), "rows": summarize(records, rows, budgets), "records": records}
    name = args.name or ("learn_sim" if Path(args.space).stem == "single_pallet_walk" else f"learn_sim_{Path(args.space).stem}")
    write_result(name, result)
    update_benchmarks(name, "\n".join(section(result)))
    print("\n".join(section(result)))


def summarize(records: list[dict], rows: list[tuple], budgets: tuple[int, ...] = BUDGETS) -> dict:
    """Per row: the fractions executed, converged and fallen at every k, executed at some k' ≤ k
    (`executed_within`), and the converged plans of the largest k that fell (task indices, and the
    non-foot spheres that touched the terrain)."""
    table = {}
    for r, (label, init, stage, phases) in enumerate(rows):
        mine = [x for x in records if x["row"] == r]
        fell = sorted((x for x in mine if x["k"] == budgets[-1] and x["converged"] and x["fell"]),
                      key=lambda x: x["index"])
        tasks = sorted({x["index"] for x in mine})

        def within(k):
            return float(np.mean([any(x["success"] for x in mine if x["index"] == i and x["k"] <= k) for i in tasks]))

        table[label] = {"init": Path(init).name, "warm_stage": stage, "phases_optimized": phases, **{
            str(k): {"executed": float(np.mean([x["success"] for x in mine if x["k"] == k])),
                     "converged": float(np.mean([x["converged"] for x in mine if x["k"] == k])),
                     "fell": float(np.mean([x["fell"] for x in mine if x["k"] == k])),
                     "executed_within": within(k)} for k in budgets},
            "converged_but_fell": {"tasks": [x["index"] for x in fell],
                                   "touched": sorted({name for x in fell for name in x["unplanned_contacts"]})}}
    return table


def section(result: dict) -> list[str]:
    """The BENCHMARKS.md section of a result."""
    budgets = result.get("budgets", BUDGETS)
    lines = [f"## Learned initialization in simulation: Fig. 8 (`bench/learn_sim.py`, {result['date']})", "",
             f"{result['machine']}, code {result['code']}, load average {result['load_average_start']:.1f} at start, "
             f"{result['load_average_end']:.1f} at end, `--jobs {result['jobs']}`, {result['wall_seconds'] / 60:.0f} min. "
             f"Task space `{result['space']}`; the first {result['tasks']} held-out tasks "
             f"{result.get('task_source', 'of the `bench/learn.py` run in `' + Path(result['run']).name + '` (seed 1)')}"
             f"; initializer rows as labelled. Each plan: `plan` with at most k LM "
             "iterations in all, whatever stage it stopped in, then executed in MuJoCo by the whole-body "
             "controller; success = the goal reached (10 cm, 0.2 rad) without a fall. In brackets: the fraction "
             "of the plans that had converged (violation ≤ 1e-3 and, with costs, settled) within k.", "",
             "| initializer | " + " | ".join(f"k = {k}" for k in budgets) + " |", "|---|" + "---|" * len(budgets)]
    for label, r in result["rows"].items():
        lines.append(f"| {label} | " + " | ".join(
            f"{r[str(k)]['executed']:.0%} ({r[str(k)]['converged']:.0%})" for k in budgets) + " |")
        if "executed_within" in r[str(budgets[0])]:
            lines.append(f"| {label}: executed at some k' ≤ k | " + " | ".join(
                f"{r[str(k)]['executed_within']:.0%}" for k in budgets) + " |")
    lines += ["", f"Converged plans (k = {budgets[-1]}) that fell, and the robot's spheres other than the feet that "
              "touched the terrain in those runs (the centroidal model keeps the feet, not the legs, off the terrain):", ""]
    for label, r in result["rows"].items():
        fell = r["converged_but_fell"]
        lines.append(f"- {label}: {len(fell['tasks'])} (tasks {', '.join(map(str, fell['tasks'])) or 'none'})"
                     + (f"; {', '.join(fell['touched'])}" if fell["touched"] else "") + ".")
    return lines


if __name__ == "__main__":
    main()
