"""Which part of a learned guess costs the iterations: the network's guess and the task's own solution mixed by category.

    .venv/bin/python bench/learn_guess.py [--space tasks/flat_trot.yaml] [--init flat_trot] [--tasks 20]
                                          [--name learn22_guess_flat_trot]

The TOWR-costs paper (Sec. IV-B) found by initializing some categories of variables from A_θ and
the others from the Heuristic that the base positions, phase durations and forces matter most.
Here the comparison is against a perfect guess instead: for each of the first --tasks held-out
tasks (seed 1, `legplan.learn.dataset.dataset_items`) the task is solved from the Heuristic
(N_h = 100 LM iterations; the oracle), and `plan` runs with the learned path's budget (N_θ = 25,
`learn dataset --init`'s parameters) from near-solution guesses:

* `solution` — the oracle itself, `network` — the initializer's guess A_θ(x);
* `network but C` — the network's guess with category C (`legplan.learn.layout.CATEGORIES`) taken
  from the solution: what a perfect prediction of C alone would save;
* `solution but C` — the solution with C taken from the network: what the network's error in C
  alone costs.

Per start: converged tasks, median and mean LM iterations of the converged ones, and the RMS
difference of the guess from the solution by category (value and derivative nodes apart). Writes
bench/results/<name>.json and the <name> section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import os
import time
from dataclasses import replace

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numpy as np  # noqa: E402
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402

SEED = 1
N_H = 100


class Guess:
    """A near-solution initializer that hands back fixed values (a mixed guess)."""

    near_solution = True

    def __init__(self, values: dict):
        self.values = values

    def __call__(self, *_):
        return {k: np.array(v) for k, v in self.values.items()}


def order_of(part: np.ndarray) -> np.ndarray:
    """0 for value, 1 for derivative entries of a node category's flat (nodes, 2, 3) vector."""
    return np.tile(np.repeat([0, 1], 3), part.size // 6)


def main() -> None:
    from legplan.dyn.init import heuristic
    from legplan.dyn.planner import plan
    from legplan.learn.dataset import DatasetWorker, dataset_items
    from legplan.learn.layout import join, split
    from legplan.learn.space import read_space

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--space", default="tasks/flat_trot.yaml")
    parser.add_argument("--init", default="flat_trot", help="a shipped initializer's name or an init.h5")
    parser.add_argument("--tasks", type=int, default=20)
    parser.add_argument("--name", default="learn_guess")
    args = parser.parse_args()
    space = read_space(ROOT / args.space)
    worker = DatasetWorker(space, args.init, 25)
    network = worker.initializer
    categories = [c for c in network.layout if network.layout[c] > 0]
    starts = ["solution", "network", *(f"network but {c}" for c in categories), *(f"solution but {c}" for c in categories)]
    records = {name: [] for name in starts}
    errors = []
    loads, t0 = [load_average()], time.perf_counter()
    for index, task, x in dataset_items(space, args.tasks, SEED, worker):
        oracle = plan(task, worker.model, worker.terrain, replace(worker.params, iteration_budget=N_H), heuristic)
        if not oracle.success:
            continue
        solution = split(join(oracle.solve.values), network.layout)
        guess = split(network.net.predict(x), network.layout)
        errors.append({f"{c}_{'vd'[o]}": float(np.sqrt(np.mean((guess[c] - solution[c])[order_of(guess[c]) == o] ** 2)))
                       for c in categories for o in (0, 1)})
        for name in starts:
            if name in ("solution", "network"):
                values = solution if name == "solution" else guess
            else:
                base, _, category = name.split(" ")
                values = dict(guess if base == "network" else solution)
                values[category] = (solution if base == "network" else guess)[category]
            result = plan(task, worker.model, worker.terrain, worker.params, Guess(values))
            records[name].append({"index": index, "success": bool(result.success),
                                  "iterations": int(result.solve.iterations), "cost": float(result.solve.cost)})
        loads.append(load_average())
        print(index, {name: records[name][-1]["iterations"] for name in starts}, flush=True)
    result = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="minutes"), "machine": machine(),
              "code": code_version(), "space": args.space, "init": args.init, "tasks": args.tasks,
              "oracle_converged": len(errors), "load_average": [min(loads), max(loads)],
              "wall_seconds": time.perf_counter() - t0, "records": records,
              "guess_rms": {key: float(np.sqrt(np.mean([e[key] ** 2 for e in errors]))) for key in errors[0]}}
    write_result(args.name, result)
    update_benchmarks(args.name, markdown(result, args.name))
    print(markdown(result, args.name))


def markdown(result: dict, name: str) -> str:
    lines = [f"## {name} — which part of the learned guess costs the iterations (`bench/learn_guess.py`, "
             f"{result['date'].replace('T', ' ')} UTC, {result['machine']}, code {result['code']}, load average "
             f"{result['load_average'][0]:.1f}–{result['load_average'][1]:.1f}; iteration counts do not depend on the load)",
             "", f"Space `{result['space']}`, initializer `{result['init']}`, the first {result['tasks']} held-out tasks "
             f"(seed {SEED}), {result['oracle_converged']} of them solved from the Heuristic (N_h = {N_H}): the solution. "
             "Each start planned with the learned path's budget of 25 LM iterations.", "",
             "| start | converged | median iterations | mean iterations |", "|---|---|---|---|"]
    for start, rows in result["records"].items():
        its = [r["iterations"] for r in rows if r["success"]]
        lines.append(f"| {start} | {len(its)}/{len(rows)} | {np.median(its) if its else float('nan'):.1f} "
                     f"| {np.mean(its) if its else float('nan'):.1f} |")
    lines += ["", "RMS of the network's guess minus the solution (value nodes v, derivative nodes d; m, m/s, rad, "
              "rad/s, N, N/s): " + ", ".join(f"{k} {v:.3g}" for k, v in result["guess_rms"].items()) + "."]
    return "\n".join(lines)


if __name__ == "__main__":
    main()
