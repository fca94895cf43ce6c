"""Benchmark of warm replanning (`legplan.dyn.replan`, issue 39 item 3): CPU time of a replan of the
rest of a 16-footstep pallet plan from a measured state, against the issue's target (median ≤ 50 ms,
p95 ≤ 100 ms, one core).

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan.py [--runs 3] [--times 6] [--no-append] [--from-json]

* The plan: the Single Pallet walk (4 strides, 16 footsteps, 5.5 s) from (-1.0, 0, 0) to (0.6, 0, 0)
  with the paper's costs (`PAPER`), planned once by `legplan.dyn.planner.plan` (its CPU time reported).
* Replans: from the plan's own state at `--times` instants spread over [0.3 s, T − 0.5 s], once as it
  is (unperturbed) and once with 0.1 m/s added to the lateral base velocity (a push), each warm-started
  from the plan shifted to t (the default "projection" warm stage; `--horizon H` freezes the plan
  after H s, `legplan.dyn.replan.ReplanParams`). CPU seconds are the process time of `replan`
  (building and solving), BLAS and CHOLMOD held to one thread; also the wall seconds of building
  the problem and the CPU per LM iteration.
* `--runs` repeats the whole set; per run the median and p95 over its replans, reported: the median
  over runs of each. Also the LM iterations and the share that converged.

`--param KEY=VALUE` sets a `ReplanParams` field (e.g. `window=1.5`, `max_iterations=2`); `--result NAME`
writes bench/results/NAME.json (default replan.json) and replaces the NAME section of BENCHMARKS.md.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402

TASK = ((-1.0, 0.0, 0.0), (0.6, 0.0, 0.0))
PUSH_VELOCITY = 0.1  # m/s added to the lateral base velocity of the perturbed states
TARGET_MEDIAN, TARGET_P95 = 0.050, 0.100  # s


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--times", type=int, default=6)
    parser.add_argument("--horizon", type=float, default=None, help="s (ReplanParams.horizon; default: none)")
    parser.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                        help="a ReplanParams field (legplan.dyn.replan), e.g. window=1.5; repeatable")
    parser.add_argument("--result", default="replan", help="bench/results/<name>.json and the BENCHMARKS.md section")
    parser.add_argument("--no-append", action="store_true", help="do not touch BENCHMARKS.md")
    parser.add_argument("--from-json", action="store_true",
                        help="rewrite the BENCHMARKS.md section from bench/results/replan.json, no runs")
    args = parser.parse_args()
    if args.from_json:
        import json

        result = json.loads((ROOT / "bench" / "results" / f"{args.result}.json").read_text())
        args.runs, args.times = len(result["runs"]), len(result["runs"][0]["rows"]) // 2
        args.horizon = result.get("horizon")
        update_benchmarks(args.result, markdown(result, args))
        return

    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynTask
    from legplan.dyn.replan import MeasuredState, ReplanParams, replan
    from legplan.dyn.settings import PAPER
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.specio import apply_overrides
    from legplan.terrain.spec import build_map

    load_start = load_average()
    model = centroidal_model(load_robot("anymal"), PAPER, "paper")
    terrain = TerrainModel(build_map(ROOT / "maps" / "single_pallet.yaml"))
    task = DynTask(*TASK, "walk", 4, 5.5)
    cpu = time.process_time()
    planned = plan(task, model, terrain, PAPER)
    plan_cpu = time.process_time() - cpu
    footsteps = planned.problem.form.footsteps
    print(f"plan: {planned.status.name}, {planned.solve.iterations} iterations, {plan_cpu:.2f} s CPU, "
          f"{footsteps} footsteps", flush=True)
    times = np.linspace(0.3, task.duration - 0.5, args.times)
    settings = apply_overrides(ReplanParams(horizon=args.horizon), dict(item.split("=", 1) for item in args.param),
                               "--param", "replan")
    runs = []
    for run in range(args.runs):
        rows = []
        for t in times:
            state = MeasuredState.from_samples(planned.samples, t)
            pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0, PUSH_VELOCITY, 0],
                                   state.base_ang_vel, state.feet_pos)
            for kind, measured in (("unperturbed", state), ("pushed", pushed)):
                out = replan(planned, measured, model, terrain, PAPER, settings=settings)
                rows.append({"t": float(state.t), "kind": kind, "cpu_seconds": out.cpu_seconds,
                             "setup_seconds": out.plan.setup_seconds, "iterations": out.iterations,
                             "success": out.success, "scaled_violation": out.scaled_violation})
                print(f"run {run}: t = {state.t:.2f} s {kind}: {out.status.name}, {out.iterations} iterations, "
                      f"{out.cpu_seconds * 1e3:.0f} ms CPU", flush=True)
        cpu_s = np.array([r["cpu_seconds"] for r in rows])
        runs.append({"rows": rows, "median": float(np.median(cpu_s)), "p95": float(np.percentile(cpu_s, 95)),
                     "median_iterations": float(np.median([r["iterations"] for r in rows])),
                     "median_setup": float(np.median([r["setup_seconds"] for r in rows])),
                     "cpu_per_iteration": float(np.median([(r["cpu_seconds"] - r["setup_seconds"])
                                                           / max(r["iterations"], 1) for r in rows])),
                     "converged": float(np.mean([r["success"] for r in rows]))})
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
              "load_start": load_start, "load_end": load_average(), "plan_status": planned.status.name,
              "plan_iterations": int(planned.solve.iterations), "plan_cpu_seconds": plan_cpu,
              "footsteps": int(footsteps), "task": TASK, "push_velocity": PUSH_VELOCITY, "runs": runs,
              "horizon": args.horizon, "replan_settings": vars(settings),
              "median_setup": float(np.median([r["median_setup"] for r in runs])),
              "cpu_per_iteration": float(np.median([r["cpu_per_iteration"] for r in runs])),
              "median": float(np.median([r["median"] for r in runs])),
              "p95": float(np.median([r["p95"] for r in runs])),
              "median_iterations": float(np.median([r["median_iterations"] for r in runs])),
              "converged": float(np.median([r["converged"] for r in runs]))}
    path = write_result(args.result, result)
    print(f"wrote {path}: median {result['median'] * 1e3:.0f} ms, p95 {result['p95'] * 1e3:.0f} ms CPU")
    if not args.no_append:
        update_benchmarks(args.result, markdown(result, args))


def pallet_plan():
    """The bench's plan as `main` makes it: the planner's model of ANYmal, the single pallet map, the
    task (`TASK`, walk, 4 strides, 5.5 s) and its plan with the paper's costs; for the benches that
    replan the same plan (`bench/replan_floor.py`, `bench/replan_profile.py`)."""
    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynTask
    from legplan.dyn.settings import PAPER
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain.spec import build_map

    model = centroidal_model(load_robot("anymal"), PAPER, "paper")
    terrain = TerrainModel(build_map(ROOT / "maps" / "single_pallet.yaml"))
    task = DynTask(*TASK, "walk", 4, 5.5)
    return model, terrain, task, plan(task, model, terrain, PAPER)


def markdown(r: dict, args) -> str:
    met = "met" if r["median"] <= TARGET_MEDIAN and r["p95"] <= TARGET_P95 else "not met"
    per_run = ", ".join(f"{x['median'] * 1e3:.0f}/{x['p95'] * 1e3:.0f}" for x in r["runs"])
    horizon = "none (the whole rest moves)" if r.get("horizon") is None else f"{r['horizon']} s"
    chosen = r.get("replan_settings") or {}
    shown = ", ".join(f"{k} = {chosen[k]}" for k in ("window", "max_iterations", "geodesic_acceleration") if k in chosen)
    horizon += f"; `ReplanParams` {shown}" if shown else ""
    left = [x.get("scaled_violation", float("nan")) for run in r["runs"] for x in run["rows"]]
    return f"""## replan — warm replanning of a 16-footstep pallet plan (`bench/replan.py`, {r['date']}, {r['machine']}, code {r['code']}; load average {r['load_start']:.1f} at start, {r['load_end']:.1f} at end: shared machine, other engineers' jobs running, timings noisy)

Single Pallet walk {r['task'][0]} → {r['task'][1]}, 4 strides, {r['footsteps']} footsteps, 5.5 s, the paper's costs;
first plan {r['plan_status']}, {r['plan_iterations']} iterations, {r['plan_cpu_seconds']:.1f} s CPU. Replans from the
plan's own state at {args.times} instants in [0.3, 5.0] s, unperturbed and with +{r['push_velocity']} m/s lateral
base velocity, warm-started from the plan shifted to t (one "projection" solve), horizon {horizon};
CPU = process time of `legplan.dyn.replan.replan` (build + solve), one thread. {args.runs} runs; median over runs:

| metric | measured | target (issue 39) | ratio |
|---|---|---|---|
| median CPU per replan | {r['median'] * 1e3:.0f} ms | ≤ {TARGET_MEDIAN * 1e3:.0f} ms | {r['median'] / TARGET_MEDIAN:.1f}× |
| p95 CPU per replan | {r['p95'] * 1e3:.0f} ms | ≤ {TARGET_P95 * 1e3:.0f} ms | {r['p95'] / TARGET_P95:.1f}× |
| median LM iterations | {r['median_iterations']:.0f} | | |
| median build (wall) | {r.get('median_setup', float('nan')) * 1e3:.0f} ms | | |
| median CPU per LM iteration | {r.get('cpu_per_iteration', float('nan')) * 1e3:.0f} ms | | |
| converged | {r['converged'] * 100:.0f} % | | |
| scaled violation left, median / max | {np.median(left):.1e} / {np.max(left):.1e} | | |

Per run median/p95 (ms): {per_run}. Target {met}; the first plan took
{r['plan_cpu_seconds'] / max(r['plan_iterations'], 1) * 1e3:.0f} ms CPU per LM iteration.
{push_section()}{tasks_section()}"""


def push_section() -> str:
    """The brackets of bench/replan_push.py's JSON, when it exists."""
    import json

    path = ROOT / "bench" / "results" / "replan_push.json"
    if not path.exists():
        return ""
    r = json.loads(path.read_text())
    if "rows" not in r or not r["rows"] or "survived" not in r["rows"][0]:
        return ""
    lines = []
    for x in r["rows"]:
        runs = [run for run in x["runs"] if run["replans"]]
        cpu = [run["replan_cpu_median"] for run in runs]
        worst = [run["replan_cpu_max"] for run in runs]
        converged = sum(run["replans_converged"] for run in runs)
        total = sum(run["replans"] for run in runs)
        failed = "—" if x["failed"] == float("inf") else f"{x['failed']:.1f}"
        lines.append(f"| {x['case']} | {x['loop']} | {x['survived']:.1f} | {failed} | "
                     + (f"{converged}/{total} | {np.median(cpu) * 1e3:.0f} / {max(worst) * 1e3:.0f} |" if runs else "— | — |"))
    return f"""
Push, open vs closed loop (`bench/replan_push.py`, {r['date']}, code {r['code']}, load {r['load_start']:.1f} → {r['load_end']:.1f}):
+y push on the trunk at half the plan for {r['push_duration']} s, its impulse doubled from 4 N s until a run fails, then
bisected; closed loop replans every {r['period']} s (`dyn simulate --replan`). Plans with `DynParams()` (no costs).
The simulation waits for each replan (no latency modelled); the replans' CPU is listed so that it shows.
One run per impulse (deterministic).

| case | loop | largest survived (N s) | smallest failed (N s) | replans converged (all runs) | replan CPU median / max (ms) |
|---|---|---|---|---|---|
""" + "\n".join(lines) + "\n"


def tasks_section() -> str:
    """The counts of bench/replan_tasks.py's JSON, when it exists."""
    import json

    path = ROOT / "bench" / "results" / "replan_tasks.json"
    if not path.exists():
        return ""
    r = json.loads(path.read_text())
    planned = max(r["planned"], 1)
    cpu = [c for row in r["rows"] if "closed" in row for c in row["closed"]["replan_cpu"]]
    converged = sum(row["closed"]["replans_converged"] for row in r["rows"] if "closed" in row)
    return f"""
Sampled single-pallet tasks with a random push (`bench/replan_tasks.py`, {r['date']}, code {r['code']}, load
{r['load_start']:.1f} → {r['load_end']:.1f}): tasks {r['first']}–{r['first'] + r['tasks'] - 1} of `tasks/single_pallet_walk.yaml`
(seed {r['seed']}, as `bench/pallet_tasks.py`), planned with `DynParams()`; per task a ±y push of
{r['impulse'][0]:g}–{r['impulse'][1]:g} N s for {r['push_duration']} s at a uniform time in [0.25, 0.75] of the plan
(seeded per task); closed loop replans every {r['period']} s.

| tasks | planned | executed open loop | executed closed loop | replans converged | replan CPU median / p95 (ms) |
|---|---|---|---|---|---|
| {r['tasks']} | {r['planned']} | {r['executed_open']} ({100 * r['executed_open'] / planned:.0f} %) | {r['executed_closed']} ({100 * r['executed_closed'] / planned:.0f} %) | {converged}/{len(cpu)} | {np.median(cpu) * 1e3:.0f} / {np.percentile(cpu, 95) * 1e3:.0f} |
"""


if __name__ == "__main__":
    main()
