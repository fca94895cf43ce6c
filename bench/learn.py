"""Benchmark of the learned initializer (TOWR-costs paper, Sec. IV-V, Algorithm 1): Heuristic vs LearnedInit.

    .venv/bin/python bench/learn.py [--space tasks/single_pallet_walk.yaml] [--n 300] [--held-out 100]
                                    [--cycles 3] [--jobs 2] [--timing-tasks 20] [--feasibility-tasks 50]
                                    [--out bench/results/learn]

1. `legplan learn cycle SPACE --n N --seed 0 --cycles K --resume -o OUT/cycle`: Algorithm 1 on the
   training tasks (Heuristic with N_h = 100 iterations in all, then per cycle filter, train,
   LearnedInit with N_θ = 25). Artefacts already in OUT are reused (`--resume`), so a long run can be
   continued and its parts computed elsewhere.
2. `legplan learn dataset` of --held-out tasks of another seed (1) from the Heuristic (N_h = 100) and
   from every cycle's init.h5 (N_θ = 25), and from the last one with `--warm-stage projection` (the
   network's guess projected onto the constraints, its cost not optimized), with `--warm-stage polish`
   (the projection, its costs optimized where they exceed the training filter's bound) and with
   `--optimize-phases` (the phase durations optimized too, from the network's timing: the gait's
   when it was trained on fixed-timing outcomes), reused when present.
3. Per held-out set (the paper's Fig. 6): convergence rate, median iterations and solve seconds of the
   converged tasks (wall time inside a one-thread worker), final cost median / p90 / max and max ÷
   median, peak foot force (median over converged tasks of the largest |f| of the 10 ms samples).
   Fig. 8 without the simulator, phase durations fixed at their initialized values or optimized
   (the paper's dotted and solid curves), read two ways on the budgets k = 0 … 25: converged within k iterations (read off the dataset's one
   solve per task), and feasible after k iterations — `plan` with at most k iterations on the first
   --feasibility-tasks held-out tasks, its values checked against every constraint of the full
   problem (tolerance 1e-3; k = 0 is the raw guess: the paper's "executable without optimization").
4. Time to a converged trajectory on one core: `plan` from the last init.h5 (every warm stage, and the
   costs with the phase durations optimized) on --timing-tasks held-out tasks in this process (one
   BLAS thread), CPU seconds (`time.process_time`) of the whole call (problem build, solve,
   sampling), median over the converged ones; and per LM iteration (the paper's Table I, "Full" vs
   "No Phase"): the median over those tasks of CPU seconds ÷ iterations.
5. Dataset throughput: tasks/s of the batch layer for every dataset computed in this run.

`--phases`: Algorithm 1 with the phase durations optimized (`learn cycle --optimize-phases`): the
Heuristic rows optimize them too, the networks predict them, and their rows keep them fixed at the
predicted values (the paper's dotted curves of Fig. 8) except the "phases optimized" row (solid).

Writes bench/results/learn.json and the learn section of BENCHMARKS.md (for another space than the single
pallet walk: learn_<space name>.json and its own section; with --phases, `_phases` appended).
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy loads BLAS

import numpy as np  # noqa: E402
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402

LEGPLAN = [sys.executable, "-c", "import sys; from legplan.cli.main import cli; sys.argv[0] = 'legplan'; cli()"]
BUDGETS = (0, 1, 2, 3, 5, 10, 25)
TOLERANCE = 1e-3


def run(*args) -> float:
    """Run a legplan command (exit 0 or 1 accepted: 1 = some task raised), return its wall time."""
    t0 = time.perf_counter()
    code = subprocess.run([*LEGPLAN, *map(str, args), "-q"], cwd=ROOT).returncode
    if code not in (0, 1):
        sys.exit(f"legplan {' '.join(map(str, args))}: exit {code}")
    return time.perf_counter() - t0


def peak_force(space, y: np.ndarray, layout: dict) -> float:
    """Largest |f| (N) of any foot over the 10 ms samples of solution y (on its own timing when y
    holds the phase durations)."""
    from legplan.dyn.planner import sample_solution
    from legplan.dyn.problem import DynParams, DynTask, task_formulation
    from legplan.dyn.timing import PHASES, PhaseTiming
    from legplan.learn.layout import split

    params = DynParams()
    form = task_formulation(DynTask((0, 0, 0), (0, 0, 0), space.gait, space.strides, space.duration), params)
    values = split(y, layout)
    if PHASES in values:
        form = PhaseTiming(form, params.phase_min).formulation(values[PHASES])
    forces = sample_solution(form, values)["forces"]
    return float(np.linalg.norm(forces, axis=-1).max())


def outcome(path: Path, space) -> dict:
    """Fig. 6 and Fig. 8 numbers of one dataset.h5 (module docstring, 3)."""
    from legplan.learn.dataset import read_dataset
    from legplan.learn.figures import success_within

    data = read_dataset(path)
    ok = np.asarray(data["success"], bool)
    it, cost, sec = (np.asarray(data[k], float) for k in ("iterations", "cost", "seconds"))
    q = (lambda a, p: float(np.quantile(a[ok], p)) if ok.any() else float("nan"))
    peaks = [peak_force(space, y, data["layout"]) for y in data["y"][ok]]
    return {"tasks": int(ok.size), "converged": float(ok.mean()), "median_iterations": q(it, 0.5),
            "median_seconds": q(sec, 0.5), "cost_median": q(cost, 0.5), "cost_p90": q(cost, 0.9),
            "cost_max": q(cost, 1.0), "cost_max_over_median": q(cost, 1.0) / q(cost, 0.5),
            "peak_force_median": float(np.median(peaks)) if peaks else float("nan"),
            "success_within": dict(zip(map(str, BUDGETS), success_within(ok, it, np.array(BUDGETS)).tolist()))}


def feasibility_within(init: str, space, tasks: np.ndarray, warm_stage: str = "costs", phases: bool = False) -> dict:
    """Fig. 8 by the constraints (module docstring, 3): for every budget k, `plan` with at most k LM
    iterations on each task, and the max violation of its values against every constraint of the
    space's full problem (fine sampling and the costs' constraints), whatever stage the planner
    stopped in (on the plan's own timing when the durations are optimized). k = 0 is the
    initializer's raw guess."""
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynTask, build_problem
    from legplan.learn.dataset import DatasetWorker, solver_params

    worker = DatasetWorker(space, str(init), None)
    full = solver_params(space.costs, None)
    within, medians = {}, {}
    for k in BUDGETS:
        params = solver_params(space.costs, k, warm_stage, phases)
        violations = []
        for row in tasks:
            task = DynTask(tuple(row[:3]), tuple(row[3:]), space.gait, space.strides, space.duration)
            values = plan(task, worker.model, worker.terrain, params, worker.initializer).solve.values
            problem = build_problem(task, worker.model, worker.terrain, full, lambda *_: values)
            violations.append(max(float(c.violation(np.asarray(c.block.evaluate([values[v] for v in c.block.variables],
                                                                                 False)[0])).max(initial=0.0))
                                  for c in problem.constraints))
        v = np.array(violations)
        within[str(k)], medians[str(k)] = float(np.mean(v <= TOLERANCE)), float(np.median(v))
    return {"feasible_within": within, "median_violation": medians}


def one_core_times(init: Path, space, tasks: np.ndarray, warm_stage: str = "costs", phases: bool = False) -> dict:
    """CPU seconds of `plan` from init.h5 on these tasks, in this process, and per iteration
    (module docstring, 4)."""
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynTask
    from legplan.learn.dataset import DatasetWorker, solver_params

    worker = DatasetWorker(space, str(init), None)
    params = solver_params(space.costs, 25, warm_stage, phases)
    seconds, converged, iterations, costs = [], [], [], []
    for row in tasks:
        task = DynTask(tuple(row[:3]), tuple(row[3:]), space.gait, space.strides, space.duration)
        t0 = time.process_time()
        result = plan(task, worker.model, worker.terrain, params, worker.initializer)
        seconds.append(time.process_time() - t0)
        converged.append(result.success)
        iterations.append(result.solve.iterations)
        costs.append(result.solve.cost)
    ok = np.array(converged)
    median = (lambda a: float(np.median(np.array(a)[ok])) if ok.any() else float("nan"))
    per_iteration = np.array(seconds) / np.maximum(iterations, 1)
    return {"tasks": len(ok), "converged": float(ok.mean()), "median_cpu_seconds": median(seconds),
            "median_iterations": median(iterations), "median_cost": median(costs),
            "median_cpu_seconds_per_iteration": median(per_iteration)}


def main() -> None:
    from legplan.dyn.settings import WARM_STAGES
    from legplan.learn.space import read_space

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--space", default="tasks/single_pallet_walk.yaml")
    parser.add_argument("--n", type=int, default=300)
    parser.add_argument("--held-out", type=int, default=100)
    parser.add_argument("--cycles", type=int, default=3)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--timing-tasks", type=int, default=20)
    parser.add_argument("--feasibility-tasks", type=int, default=50)
    parser.add_argument("--out", default="bench/results/learn")
    parser.add_argument("--phases", action="store_true",
                        help="Algorithm 1 with the phase durations optimized (`learn cycle --optimize-phases`): the "
                             "Heuristic rows optimize them, the networks predict them (kept fixed at their "
                             "values unless a row says optimized); a section of its own")
    args = parser.parse_args()
    out = (ROOT / args.out).resolve()
    (out / "cycle").mkdir(parents=True, exist_ok=True)
    space = read_space(ROOT / args.space)
    started, code = load_average(), code_version()
    throughput = {}
    t0 = time.perf_counter()
    run("learn", "cycle", ROOT / args.space, "--cycles", args.cycles, "--n", args.n, "--seed", 0, "--jobs", args.jobs,
        "-o", out / "cycle", "--resume", *(["--optimize-phases"] if args.phases else []))
    cycle_seconds = time.perf_counter() - t0
    inits = [out / "cycle" / f"init_{k}.h5" for k in range(1, args.cycles + 1)]
    rows = {}
    last = len(inits)
    for label, init, iterations, warm_stage, phases in [("Heuristic (N_h = 100)", "heuristic", 100, "costs", args.phases)] + \
            [(f"LearnedInit cycle {k} (N_θ = 25)", init, 25, "costs", False) for k, init in enumerate(inits, 1)] + \
            [(f"LearnedInit cycle {last}, projection (N_θ = 25)", inits[-1], 25, "projection", False),
             (f"LearnedInit cycle {last}, polish (N_θ = 25)", inits[-1], 25, "polish", False),
             (f"LearnedInit cycle {last}, phases optimized (N_θ = 25)", inits[-1], 25, "costs", True)]:
        path = out / ("heldout_heuristic.h5" if init == "heuristic" else f"heldout_{Path(init).stem}.h5")
        if warm_stage != "costs":
            path = path.with_name(f"{path.stem}_{warm_stage}.h5")
        if phases and init != "heuristic":
            path = path.with_name(f"{path.stem}_phases.h5")
        if not path.exists():
            wall = run("learn", "dataset", ROOT / args.space, "--n", args.held_out, "--seed", 1, "--init", init,
                       "--iterations", iterations, "--warm-stage", warm_stage, "--jobs", args.jobs, "-o", path,
                       *(["--optimize-phases"] if phases else []))
            throughput[label] = args.held_out / wall
        rows[label] = outcome(path, space)
        rows[label].update(feasibility_within(init, space, _tasks(path)[:args.feasibility_tasks], warm_stage, phases))
    held_out_tasks = _tasks(out / "heldout_heuristic.h5")[:args.timing_tasks]
    timing = {stage: one_core_times(inits[-1], space, held_out_tasks, stage) for stage in WARM_STAGES}
    timing["costs, phases optimized"] = one_core_times(inits[-1], space, held_out_tasks, "costs", True)
    cycles = json.loads((out / "cycle" / "cycles.json").read_text())["cycles"]
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code, "load_average_start": started,
              "load_average_end": load_average(), "space": args.space, "train_tasks": args.n,
              "held_out_tasks": args.held_out, "jobs": args.jobs, "cycle_seconds_this_run": cycle_seconds,
              "held_out": rows, "one_core": timing, "throughput_tasks_per_second": throughput, "cycles": cycles}
    name = "learn" if space.name == "single_pallet_walk" else f"learn_{space.name}"  # one section per space
    name += "_phases" if args.phases else ""
    result["phases_in_training"] = args.phases
    result["space_shape"] = {"name": space.name, "gait": space.gait, "strides": space.strides,
                             "duration": space.duration, "costs": space.costs}
    write_result(name, result)
    update_benchmarks(name, "\n".join(section(result, args)))
    print("\n".join(section(result, args)))


def _tasks(path: Path) -> np.ndarray:
    import h5py

    with h5py.File(path, "r") as f:
        return f["tasks"][()]


def section(result: dict, args) -> list[str]:
    """The BENCHMARKS.md section of a result."""
    rows, timing, cycles, shape = result["held_out"], result["one_core"], result["cycles"], result["space_shape"]
    title = "" if shape["name"] == "single_pallet_walk" else f", {shape['name']}"
    if result.get("phases_in_training"):
        title += ", phase durations optimized in training"
    lines = [f"## Learned initialization{title} (`bench/learn.py`, {result['date']})", "",
             f"{result['machine']}, code {result.get('code', 'not recorded')}, load average "
             f"{result['load_average_start']:.1f} at start, "
             f"{result['load_average_end']:.1f} at end (shared machine). Task space `{result['space']}` ({shape['name']}: "
             f"{shape['gait']}, {shape['strides']} strides, {shape['duration']:g} s, costs {shape['costs']}); Algorithm 1 on {result['train_tasks']} training "
             f"tasks (seed 0, `learn cycle --cycles {args.cycles}"
             f"{' --optimize-phases' if result.get('phases_in_training') else ''}`), evaluated on {result['held_out_tasks']} held-out "
             f"tasks (seed 1), `--jobs {result['jobs']}`. N is the LM iteration budget of the whole plan "
             "(all planner stages). Seconds are solve wall times inside one-thread workers on the shared machine; "
             "the one-core row below is CPU time.", "",
             "| initializer (held-out) | converged | median it. | median solve (s) | cost median / p90 / max "
             "| max ÷ median | peak |f| median (N) | raw output feasible (median violation) |",
             "|---|---|---|---|---|---|---|---|"]
    for label, r in rows.items():
        raw = {"feasible_fraction": r["feasible_within"]["0"], "median_violation": r["median_violation"]["0"]}
        lines.append(f"| {label} | {r['converged']:.0%} | {r['median_iterations']:g} | {r['median_seconds']:.2f} "
                     f"| {r['cost_median']:.3g} / {r['cost_p90']:.3g} / {r['cost_max']:.3g} "
                     f"| {r['cost_max_over_median']:.2f} | {r['peak_force_median']:.0f} | "
                     + f"{raw['feasible_fraction']:.0%} ({raw['median_violation']:.2g}) |")
    lines += ["", "Success against the iteration budget k (Fig. 8; phase durations fixed at their initialized "
              "values unless a row says optimized; fraction of the held-out tasks converged within k):", "",
              "| initializer | " + " | ".join(f"k = {k}" for k in BUDGETS) + " |",
              "|---|" + "---|" * len(BUDGETS)]
    for label, r in rows.items():
        lines.append(f"| {label} | " + " | ".join(f"{r['success_within'][str(k)]:.0%}" for k in BUDGETS) + " |")
    count = args.feasibility_tasks
    lines += ["", f"Feasible against the iteration budget k (Fig. 8's success read as \"meets every constraint of the full "
              f"problem within {TOLERANCE:g}\", costs not yet settled; `plan` with at most k iterations on the first "
              f"{count} held-out tasks; median max violation in brackets):", "",
              "| initializer | " + " | ".join(f"k = {k}" for k in BUDGETS) + " |",
              "|---|" + "---|" * len(BUDGETS)]
    for label, r in rows.items():
        lines.append(f"| {label} | " + " | ".join(
            f"{r['feasible_within'][str(k)]:.0%} ({r['median_violation'][str(k)]:.1g})" for k in BUDGETS) + " |")
    lines += ["", f"One core (this process, one BLAS thread): `plan` from the last init.h5 on {timing['costs']['tasks']} "
              "held-out tasks (problem build, solve and 10 ms sampling), to a converged trajectory:", ""]
    for stage, t in timing.items():
        lines.append(f"- warm stage {stage}: {t['converged']:.0%} converged, median {t['median_iterations']:g} iterations, "
                     f"median {t['median_cpu_seconds']:.2f} CPU s ({t['median_cpu_seconds_per_iteration']:.3f} s per "
                     f"iteration), median cost {t['median_cost']:.3g}.")
    lines.append("")
    if result["throughput_tasks_per_second"]:
        lines.append(f"Dataset throughput (`--jobs {result['jobs']}`, batch layer): " + ", ".join(
            f"{label}: {v:.2f} tasks/s" for label, v in result["throughput_tasks_per_second"].items()) + ".")
        lines.append("")
    lines += ["Training cycles (the training tasks, `cycles.json`):", "",
              "| cycle | initializer | converged | median iterations | cost median / p90 / max |", "|---|---|---|---|---|"]
    for c in cycles:
        lines.append(f"| {c['cycle']} | {c['init']} | {c['success_rate']:.0%} | {c['median_iterations']:g} "
                     f"| {c['cost_median']:.3g} / {c['cost_p90']:.3g} / {c['cost_max']:.3g} |")
    last, projection, polish, phases = (rows[f"LearnedInit cycle {args.cycles}{part} (N_θ = 25)"]
                                        for part in ("", ", projection", ", polish", ", phases optimized"))
    stages = {"costs": last, "projection": projection, "polish": polish}
    per_stage = (lambda text: "; ".join(f"{stage} {text(r, stage)}" for stage, r in stages.items()))
    lines += ["", "Targets (issue 16), LearnedInit after 3 cycles, per warm stage: converges on ≥ 95 % of held-out "
              f"tasks: {per_stage(lambda r, _: format(r['converged'], '.0%'))}. Max final cost ≤ 2× the median: "
              f"{per_stage(lambda r, _: format(r['cost_max_over_median'], '.2f') + '×')}. Median iterations ≤ 5: "
              f"{per_stage(lambda r, _: format(r['median_iterations'], 'g'))}. Median time to a converged trajectory "
              f"≤ 0.3 s on one core: {per_stage(lambda _, k: format(timing[k]['median_cpu_seconds'], '.2f') + ' s')}. "
              "Median cost against the costs' (held-out): projection "
              f"{projection['cost_median'] / last['cost_median'] - 1:+.1%}, polish {polish['cost_median'] / last['cost_median'] - 1:+.1%}."]
    full, fixed = timing["costs, phases optimized"], timing["costs"]
    ratio = full["median_cpu_seconds_per_iteration"] / fixed["median_cpu_seconds_per_iteration"]
    lines.append(f"Phase durations optimized too, from the network's timing (Fig. 8 solid against dotted): "
                 f"{phases['converged']:.0%} converged against {last['converged']:.0%} with them fixed, median "
                 f"{phases['median_iterations']:g} against {last['median_iterations']:g} iterations, median cost "
                 f"{phases['cost_median']:.3g} against {last['cost_median']:.3g} (held-out). Per LM iteration on one "
                 f"core (Table I, \"Full\" against \"No Phase\"): {full['median_cpu_seconds_per_iteration']:.3f} "
                 f"against {fixed['median_cpu_seconds_per_iteration']:.3f} CPU s, {ratio:.1f}× (the paper's pallets, "
                 "mean with costs: 417 against 117 ms, 3.6×).")
    if result["train_tasks"] < 1000:
        lines.append(f"Scale: {result['train_tasks']} training tasks, below the issue's n ≥ 1000.")
    return lines


if __name__ == "__main__":
    main()
