"""A first plan from a shipped initializer, and from a perfect one: two source trees side by side (issue 39).

    .venv/bin/python bench/learned_start.py --before /tmp/ref_381 --before-code 38107ef
        [--trot-n 100] [--pallet-n 30] [--double-n 0] [--oracle-trot 20] [--oracle-pallet 10]
        [--result learned_start] [--no-append]

Every run is a child process per tree (`PYTHONPATH` = that tree, one BLAS thread), the trees
alternating; each plans through the path `legplan learn dataset --init NAME --iterations 25` takes
(`legplan.learn.dataset.DatasetWorker`: the space's costs, the planner's model, the initializer the
name resolves to, Algorithm 1's N_θ = 25 LM iterations for the whole plan) and judges every plan
by the independent check (`legplan.validate.trajectory.check_trajectory`).

* held out: `--trot-n` tasks of tasks/flat_trot.yaml, `--pallet-n` of tasks/single_pallet_walk.yaml
  and `--double-n` of tasks/double_pallet_walk.yaml (a reference tree that does not ship that
  initializer needs the file copied into its tasks/initializers/), seed 1 (the held-out seed of the
  benchmarks before), planned from the shipped initializer of the
  space (tasks/initializers/, the same file in both trees): converged share, median LM iterations and
  median CPU seconds (`time.process_time` of `plan`: build, solve, 10 ms sampling) of the converged
  ones, their largest cost over the median, plans whose check failed.
* oracle: the first `--oracle-trot` / `--oracle-pallet` of those tasks solved from the Heuristic
  (N_h = 100), then planned again from that converged solution as the guess of a near-solution
  initializer (what a perfect network would give): iterations per stage. The Heuristic's own plans
  are compared between the trees entry by entry (the heuristic path is meant to be the same).

Writes bench/results/<result>.json and the <result> section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import os
import subprocess
import sys
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numpy as np  # noqa: E402
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402

SPACES = {"flat_trot": "tasks/flat_trot.yaml", "single_pallet_walk": "tasks/single_pallet_walk.yaml",
          "double_pallet_walk": "tasks/double_pallet_walk.yaml"}
SEED = 1
N_THETA = 25
N_H = 100


class _Replay:
    """A near-solution initializer that hands back a given solution (a perfect learned guess)."""

    near_solution = True

    def __init__(self, values):
        self.values = values

    def __call__(self, *_):
        return {k: np.array(v) for k, v in self.values.items()}


def child(space_name: str, count: int, mode: str) -> list[dict]:
    """In the tree on `sys.path`: plan `count` held-out tasks of the space from its shipped
    initializer (`learned`), or from the Heuristic and then from that solution (`oracle`)."""
    import time
    from dataclasses import replace

    from legplan.dyn.planner import plan
    from legplan.learn.dataset import DatasetWorker, dataset_items
    from legplan.learn.space import load_terrain_map, read_space
    from legplan.robots import load_robot
    from legplan.validate.trajectory import check_trajectory

    space = read_space(ROOT / SPACES[space_name])
    worker = DatasetWorker(space, space_name, N_THETA)
    robot, terrain_map = load_robot(space.robot), load_terrain_map(space)

    def run(task, params, init):
        t0 = time.process_time()
        result = plan(task, worker.model, worker.terrain, params, init)
        cpu = time.process_time() - t0
        check = check_trajectory(result.samples, worker.model, terrain_map, robot,
                                 node_times=result.problem.form.knots)
        return result, {"success": bool(result.success), "iterations": int(result.solve.iterations),
                        "cost": float(result.solve.cost), "cpu_seconds": cpu, "check_ok": bool(check.ok),
                        "stages": [[s.name, s.status.name.lower(), int(s.result.iterations)] for s in result.stages]}

    records = []
    for index, task, _ in dataset_items(space, count, SEED, worker):
        if mode == "learned":
            records.append({"index": index, **run(task, worker.params, worker.initializer)[1]})
            continue
        first, heuristic = run(task, replace(worker.params, iteration_budget=N_H), _heuristic())
        digest = hashlib.sha256(b"".join(np.ascontiguousarray(first.solve.values[k]).tobytes()
                                         for k in sorted(first.solve.values))).hexdigest()
        record = {"index": index, "heuristic": {**heuristic, "sha256": digest}}
        if first.success:
            record.update(run(task, worker.params, _Replay(first.solve.values))[1])
        records.append(record)
    return records


def _heuristic():
    from legplan.dyn.init import heuristic

    return heuristic


def run_child(tree: Path, space: str, count: int, mode: str) -> list[dict]:
    env = dict(os.environ, PYTHONPATH=str(tree))
    out = subprocess.run([sys.executable, __file__, "--child", space, str(count), mode], env=env,
                         capture_output=True, text=True, check=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def summary(records: list[dict]) -> dict:
    """Converged share, median iterations / CPU seconds and max ÷ median cost of the converged, checks."""
    done = [r for r in records if "success" in r]
    ok = [r for r in done if r["success"]]
    cost = np.array([r["cost"] for r in ok])
    return {"tasks": len(done), "converged": len(ok),
            "median_iterations": float(np.median([r["iterations"] for r in ok])) if ok else None,
            "max_iterations": int(max(r["iterations"] for r in ok)) if ok else None,
            "median_cpu_seconds": float(np.median([r["cpu_seconds"] for r in ok])) if ok else None,
            "median_cost": float(np.median(cost)) if ok else None,
            "max_over_median_cost": float(cost.max() / np.median(cost)) if ok else None,
            "check_failed_of_converged": sum(not r["check_ok"] for r in ok),
            "within_4_iterations": sum(r["iterations"] <= 4 for r in ok)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--child", nargs=3, metavar=("SPACE", "N", "MODE"), help=argparse.SUPPRESS)
    parser.add_argument("--before", type=Path, default=Path("/tmp/ref_381"))
    parser.add_argument("--before-code", default="38107ef")
    parser.add_argument("--trot-n", type=int, default=100)
    parser.add_argument("--pallet-n", type=int, default=30)
    parser.add_argument("--double-n", type=int, default=0)
    parser.add_argument("--oracle-trot", type=int, default=20)
    parser.add_argument("--oracle-pallet", type=int, default=10)
    parser.add_argument("--result", default="learned_start", help="bench/results/<name>.json and the BENCHMARKS.md section")
    parser.add_argument("--no-append", action="store_true", help="write the JSON only, not BENCHMARKS.md")
    args = parser.parse_args()
    if args.child:
        space, count, mode = args.child
        print(json.dumps(child(space, int(count), mode)))
        return
    trees = {"before": args.before, "after": ROOT}
    started = datetime.datetime.now(datetime.timezone.utc)
    loads = [load_average()]
    runs = []
    for space, count, mode in (("flat_trot", args.trot_n, "learned"), ("single_pallet_walk", args.pallet_n, "learned"),
                               ("double_pallet_walk", args.double_n, "learned"),
                               ("flat_trot", args.oracle_trot, "oracle"),
                               ("single_pallet_walk", args.oracle_pallet, "oracle")):
        if not count:
            continue
        order = ("before", "after") if len(runs) % 2 == 0 else ("after", "before")
        results = {}
        for label in order:
            results[label] = run_child(trees[label], space, count, mode)
            loads.append(load_average())
            print(space, mode, label, summary(results[label]), flush=True)
        same = None
        if mode == "oracle":
            same = all(a["heuristic"]["sha256"] == b["heuristic"]["sha256"]
                       for a, b in zip(results["before"], results["after"]))
        runs.append({"space": space, "mode": mode, "tasks": count, "order": list(order),
                     "heuristic_same_in_both_trees": same,
                     **{label: {"summary": summary(results[label]), "records": results[label]} for label in trees}})
    result = {"date": started.isoformat(timespec="seconds"), "machine": machine(), "code": code_version(),
              "before": str(args.before), "before_code": args.before_code, "load_average": loads, "runs": runs}
    result["section"] = args.result
    write_result(args.result, result)
    if not args.no_append:
        update_benchmarks(args.result, markdown(result))


def markdown(result: dict) -> str:
    loads = result["load_average"]
    lines = [f"## {result.get('section', 'learned_start')} — a first plan from the shipped initializer and from a perfect one, two trees "
             f"side by side (`bench/learned_start.py`, {result['date'][:16].replace('T', ' ')} UTC, {result['machine']}, "
             f"code {result['code']}, load average {min(loads):.1f}–{max(loads):.1f}: shared machine, CPU seconds noisy)",
             "",
             f"`before` = {result['before']} (code {result['before_code']}), `after` = this tree. Each run a child "
             f"process per tree, the trees alternating, one thread; the path of `learn dataset --init NAME "
             f"--iterations {N_THETA}` (held-out seed {SEED}); every plan judged by the independent check. "
             f"Oracle: the task solved from the Heuristic (N_h = {N_H}), then planned again from that solution "
             "as a near-solution guess.",
             "",
             "| space | start | tree | converged | median it. (max) | ≤ 4 it. | max / median cost | median cost "
             "| median CPU s | check failed |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for run in result["runs"]:
        for label in ("before", "after"):
            s = run[label]["summary"]
            start = "shipped initializer" if run["mode"] == "learned" else "own converged solution"
            lines.append(f"| {run['space']} | {start} | {label} | {s['converged']}/{s['tasks']} "
                         f"| {_number(s['median_iterations'], '.1f')} ({s['max_iterations'] or '—'}) "
                         f"| {s['within_4_iterations']} | {_number(s['max_over_median_cost'], '.2f')} "
                         f"| {_number(s['median_cost'], '.3f')} | {_number(s['median_cpu_seconds'], '.2f')} "
                         f"| {s['check_failed_of_converged']} |")
    lines += ["", "Oracle iterations by stage (median over the tasks whose stage ran; count of tasks):", ""]
    for run in result["runs"]:
        if run["mode"] != "oracle":
            continue
        for label in ("before", "after"):
            spent: dict[str, list[int]] = {}
            for record in run[label]["records"]:
                for name, _, iterations in record.get("stages", []):
                    spent.setdefault(name, []).append(iterations)
            parts = [f"{name} {np.median(its):.1f} ({len(its)})" for name, its in spent.items()]
            lines.append(f"- {run['space']}, {label}: {'; '.join(parts) or 'none converged'}")
    same = [run["heuristic_same_in_both_trees"] for run in result["runs"] if run["mode"] == "oracle"]
    lines += ["", f"Heuristic plans of the oracle tasks identical in both trees (every variable, bit for bit): "
              f"{'yes' if all(same) else 'no'}."]
    return "\n".join(lines)


def _number(value, spec: str) -> str:
    return "—" if value is None else format(value, spec)


if __name__ == "__main__":
    main()
