"""Benchmark of the learned initializer (TOWR-costs paper, Sec. IV, Algorithm 1): Heuristic vs LearnedInit.

    .venv/bin/python bench/learn.py [--space tasks/single_pallet_walk.yaml] [--n 60] [--held-out 30]
                                    [--cycles 2] [--jobs 2] [--out bench/results/learn]

Runs `legplan learn cycle SPACE --n N --seed 0` (Algorithm 1 on the training tasks: Heuristic with
N_h = 100, then per cycle filter, train, LearnedInit with N_θ = 25), then solves --held-out tasks
of another seed (1) from the Heuristic (N_h = 100) and from each cycle's init.h5 (N_θ = 25), and
reports per initializer: convergence rate, median iterations and solve time of the converged tasks,
final cost (median, p90, max), the fraction of held-out tasks converged within 5 iterations, and
the dataset throughput of the batch layer. Writes bench/results/learn.json and its section of
BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
import time
from pathlib import Path

import h5py
import numpy as np
from common import ROOT, load_average, machine, update_benchmarks, write_result

LEGPLAN = str(ROOT / ".venv" / "bin" / "legplan")


def run(*args) -> float:
    """Run a legplan command (exit 0 or 1 accepted: 1 = some task raised), return its wall time."""
    t0 = time.perf_counter()
    code = subprocess.run([LEGPLAN, *map(str, args), "-q"], cwd=ROOT).returncode
    if code not in (0, 1):
        sys.exit(f"legplan {' '.join(map(str, args))}: exit {code}")
    return time.perf_counter() - t0


def outcome(path: Path, wall: float) -> dict:
    with h5py.File(path, "r") as f:
        ok, it, cost, sec = (f[k][()] for k in ("success", "iterations", "cost", "seconds"))
    ok = ok.astype(bool)
    q = (lambda a, p: float(np.quantile(a[ok], p)) if ok.any() else float("nan"))
    return {"tasks": int(ok.size), "converged": float(ok.mean()), "median_iterations": q(it, 0.5),
            "median_seconds": q(sec, 0.5), "cost_median": q(cost, 0.5), "cost_p90": q(cost, 0.9),
            "cost_max": q(cost, 1.0), "within_5_iterations": float(np.mean(ok & (it <= 5))),
            "tasks_per_second": ok.size / wall}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--space", default="tasks/single_pallet_walk.yaml")
    parser.add_argument("--n", type=int, default=60)
    parser.add_argument("--held-out", type=int, default=30)
    parser.add_argument("--cycles", type=int, default=2)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--out", default="bench/results/learn")
    args = parser.parse_args()
    out = ROOT / args.out
    out.mkdir(parents=True, exist_ok=True)
    started = load_average()
    t0 = time.perf_counter()
    run("learn", "cycle", args.space, "--cycles", args.cycles, "--n", args.n, "--seed", 0, "--jobs", args.jobs,
        "-o", out / "cycle", "--resume")
    cycle_seconds = time.perf_counter() - t0
    rows = {}
    evaluations = [("Heuristic (N_h = 100)", "heuristic", 100)]
    evaluations += [(f"LearnedInit cycle {k} (N_θ = 25)", out / "cycle" / f"init_{k}.h5", 25)
                    for k in range(1, args.cycles + 1)]
    for label, init, iterations in evaluations:
        name = "heldout_heuristic.h5" if init == "heuristic" else f"heldout_{Path(init).stem}.h5"
        path = out / name
        wall = 0.0 if path.exists() else run("learn", "dataset", args.space, "--n", args.held_out, "--seed", 1,
                                             "--init", init, "--iterations", iterations, "--jobs", args.jobs,
                                             "-o", path)
        rows[label] = outcome(path, wall) if wall else {**outcome(path, 1.0), "tasks_per_second": float("nan")}
    cycles = json.loads((out / "cycle" / "cycles.json").read_text())["cycles"]
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "load_average": started,
              "space": args.space, "train_tasks": args.n, "held_out_tasks": args.held_out, "jobs": args.jobs,
              "cycle_seconds": cycle_seconds, "held_out": rows, "cycles": cycles}
    write_result("learn", result)
    lines = [f"## Learned initialization (`bench/learn.py`, {result['date']})", "",
             f"{machine()}, load average {started:.1f} at start (shared machine). Task space `{args.space}`; "
             f"Algorithm 1 on {args.n} training tasks (seed 0, `learn cycle --cycles {args.cycles}`), "
             f"evaluated on {args.held_out} held-out tasks (seed 1), `--jobs {args.jobs}`. Iteration caps are per "
             "planner stage (feasibility, then costs); iterations and times are totals over the stages. "
             "Small n: read the rates as ±1/√n.", "",
             "| initializer (held-out) | converged | median iterations | median solve (s) | cost median / p90 / max "
             "| converged in ≤ 5 it. | tasks/s |", "|---|---|---|---|---|---|---|"]
    for label, r in rows.items():
        lines.append(f"| {label} | {r['converged']:.0%} | {r['median_iterations']:g} | {r['median_seconds']:.2f} "
                     f"| {r['cost_median']:.3g} / {r['cost_p90']:.3g} / {r['cost_max']:.3g} "
                     f"| {r['within_5_iterations']:.0%} | "
                     + (f"{r['tasks_per_second']:.2f} |" if np.isfinite(r["tasks_per_second"]) else "— (dataset reused) |"))
    lines += ["", "Training cycles (the training tasks, `cycles.json`):", "",
              "| cycle | initializer | converged | median iterations | cost median / p90 / max |", "|---|---|---|---|---|"]
    for c in cycles:
        lines.append(f"| {c['cycle']} | {c['init']} | {c['success_rate']:.0%} | {c['median_iterations']:g} "
                     f"| {c['cost_median']:.3g} / {c['cost_p90']:.3g} / {c['cost_max']:.3g} |")
    update_benchmarks("learn", "\n".join(lines))
    print("\n".join(lines))


if __name__ == "__main__":
    main()
