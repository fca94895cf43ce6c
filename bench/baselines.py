"""Ours vs OMPL on the same problems, same machine, same run: step planning and navigation.

    .venv/bin/python bench/baselines.py [--map gap.h5 --steps steps.h5] [--step-budget 10]
        [--queries 10] [--nav-budget 1] [--control-budget 10] [--seed 0] [--only steps|nav] [--no-append]

Steps: maps/gap_crossing.yaml with the scarab2 sequence of `legplan steps generate` (as
bench/step_plan.py builds it, or --map/--steps), both variants of bench/step_plan.py ('as
generated' pairs and 'whole swings'). Ours: `legplan.stepplan.plan_sequence` (Bézier + LM); OMPL:
constrained RRT-Connect (`legplan.baselines.step`, atlas space unless --space) with --step-budget
seconds per step. Both judged by the same dense check (worst stance-foot slip, CoM margin,
clearance shortfall with the swing-foot ramp; eq. (5) length and roughness — exact for the Bézier curve, finite differences of the
dense samples for the OMPL polyline, see legplan/baselines/step.py).

Navigation: the maps of bench/nav_search.py (`MAPS`: maps/nav_30m.yaml and the ROS warehouse map
maps/ros/warehouse.yaml through `legplan.terrain.importers.import_ros`), on each its --queries
seeded start/goal pairs (`sample_queries`, same seed: the first --queries of nav_search's queries),
jueying_mini limits. Ours: kinodynamic A* and grid A* (`legplan.nav.PLANNERS`); OMPL: RRT-Connect,
RRT*, PRM* (--nav-budget s) and KPIECE1 / RRT on the double integrator (--control-budget s), query i
with seed --seed + i as `legplan baseline nav`. Wall time as each planner reports it, CPU time
(time.process_time) around each query. Metrics from `legplan.nav.artefact.trajectory_metrics` for
every planner.
Writes bench/results/baselines.json and updates its section of BENCHMARKS.md. `--only steps|nav`
runs one part: the other part's JSON entry and its BENCHMARKS.md text (up to / from the line
starting "Navigation:") are kept as they are, each with the date and load of the run that made it.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import json
import os
import sys
import tempfile
import time
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from common import BENCHMARKS, ROOT, load_average, machine, update_benchmarks, write_result  # noqa: E402


def bench_module(name: str):
    """Another bench script as a module (its scenario and query helpers are reused, not copied)."""
    spec = importlib.util.spec_from_file_location(f"bench_{name}", ROOT / "bench" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _median(values):
    values = [v for v in values if v is not None and np.isfinite(v)]
    return float(np.median(values)) if values else float("nan")


def step_rows(records) -> dict:
    dense = [r["dense"] for r in records if "dense" in r]
    ok = [r for r in records if r["success"] and "dense" in r]
    return {"planned": len(records), "succeeded": sum(bool(r["success"]) for r in records),
            "median_time": _median([r["seconds"] for r in records]),
            "mean_time": float(np.mean([r["seconds"] for r in records])),
            "max_time": float(max(r["seconds"] for r in records)),
            "worst_slip_mm": 1e3 * max((d["foot_slip"] for d in dense), default=float("nan")),
            "worst_com_margin_mm": 1e3 * min((d["com_margin"] for d in dense), default=float("nan")),
            "worst_clearance_shortfall_mm": 1e3 * max((d["shortfall_clearance"] for d in dense), default=float("nan")),
            "median_length": _median([r["dense"]["length"] for r in ok]),
            "median_roughness2": _median([r["dense"]["roughness2"] for r in ok]),
            "median_roughness3": _median([r["dense"]["roughness3"] for r in ok]),
            "failures": {int(r["index"]): r["reason"] for r in records if not r["success"]}}


def run_steps(args, progress) -> dict:
    from legplan.baselines.step import StepBaselineParams, plan_sequence_baseline
    from legplan.stepplan import StepPlanParams, plan_sequence
    from legplan.stepseq.sequence import read_steps

    step_bench = bench_module("step_plan")
    with tempfile.TemporaryDirectory() as tmp:
        if args.map is None or args.steps is None:
            map_path, steps_path = step_bench.scenario(Path(tmp), "scarab2", (-0.6, 0.0, 0.0), (0.6, 0.0, 0.0))
        else:
            map_path, steps_path = args.map, args.steps
        generated = read_steps(steps_path)
        ompl = StepBaselineParams(time_budget=args.step_budget, space=args.space, seed=args.seed)
        out = {"date": datetime.date.today().isoformat(), "load_average": {"start": load_average()},
               "configurations": len(generated), "ompl_params": ompl.as_dict(),
               "ours_params": StepPlanParams().as_dict(), "variants": {}}
        for name, seq in (("as generated", generated), ("whole swings", step_bench.merge_swings(generated))):
            pairs = range(len(seq) - 1)
            ours = plan_sequence(seq, map_path, StepPlanParams(), pairs, progress=progress(f"ours {name}"))
            theirs = plan_sequence_baseline(seq, map_path, ompl, pairs, progress=progress(f"ompl {name}"))
            out["variants"][name] = {"ours": step_rows(ours), "ompl": step_rows(theirs)}
    out["load_average"]["end"] = load_average()
    return out


def nav_rows(results, planning_times, first_times, cpu_times, grid) -> dict:
    from legplan.nav.artefact import trajectory_metrics

    metrics = [trajectory_metrics(r.trajectory, grid) for r in results]
    ok = [m for r, m in zip(results, metrics) if r.success]
    return {"queries": len(results), "succeeded": len(ok),
            "median_time": _median(planning_times), "max_time": float(max(planning_times)),
            "median_cpu_time": _median(cpu_times), "total_cpu_time": float(sum(cpu_times)),
            "median_first_solution": _median(first_times),
            "median_length": _median([m["path_length"] for m in ok]),
            "median_duration": _median([m["duration"] for m in ok]),
            "median_effort": _median([m["effort"] for m in ok]),
            "min_clearance": min((m["min_clearance"] for m in ok), default=float("nan")),
            "max_speed_axis": max((m["max_speed_axis"] for m in ok), default=float("nan")),
            "max_accel_axis": max((m["max_accel_axis"] for m in ok), default=float("nan")),
            "failures": sorted({r.reason for r in results if not r.success})}


def timed(plan, queries, progress=None):
    """[(outcome, CPU seconds)] of plan(index, query) for every query (time.process_time: all threads)."""
    out = []
    for index, query in enumerate(queries):
        if progress is not None:
            progress(index, len(queries), f"query {index}")
        cpu = time.process_time()
        outcome = plan(index, query)
        out.append((outcome, time.process_time() - cpu))
    if progress is not None:
        progress(len(queries), len(queries))
    return out


def run_nav_map(grid, queries, params, args, progress) -> dict:
    from legplan.baselines.nav import NavBaselineParams, plan_baseline
    from legplan.nav import PLANNERS

    planners = {}
    for name in ("kinoastar", "astar"):
        runs = timed(lambda i, q, name=name: PLANNERS[name](grid, q[:4], q[4:], params), queries,
                     progress(f"ours {name}"))
        results = [r for r, _ in runs]
        times = [r.planning_time for r in results]
        planners[f"ours: {name}"] = nav_rows(results, times, [t if r.success else None for r, t in zip(results, times)],
                                             [c for _, c in runs], grid)
    for planner in ("rrtconnect", "rrtstar", "prmstar", "kpiece-control", "rrt-control"):
        budget = args.control_budget if planner.endswith("control") else args.nav_budget
        settings = NavBaselineParams(planner=planner, time_budget=budget, seed=args.seed, v_max=params.v_max,
                                     a_max=params.a_max)
        # query i with seed settings.seed + i, as `legplan baseline nav` (baselines.nav.plan_queries)
        runs = timed(lambda i, q: plan_baseline(grid, q[:4], q[4:], settings, settings.seed + i), queries,
                     progress(f"ompl {planner}"))
        outcomes = [o for o, _ in runs]
        planners[f"OMPL {planner} ({budget:g} s)"] = nav_rows(
            [o.result for o in outcomes], [o.result.planning_time for o in outcomes],
            [o.time_to_first_solution for o in outcomes], [c for _, c in runs], grid)
    return planners


def run_nav(args, progress) -> dict:
    from legplan.nav import NavGrid, NavParams
    from legplan.robots import load_robot

    nav_search = bench_module("nav_search")
    navigation = load_robot("jueying_mini").navigation
    params = NavParams.for_robot(navigation)
    out = {"date": datetime.date.today().isoformat(), "load_average": {"start": load_average()},
           "seed": args.seed, "l1": navigation.inscribed_radius, "v_max": params.v_max, "a_max": params.a_max,
           "maps": {}}
    wall, cpu = time.perf_counter(), time.process_time()
    for map_name, build in nav_search.MAPS.items():
        grid = NavGrid.from_terrain(build(), lethal_radius=navigation.inscribed_radius)
        queries = nav_search.sample_queries(grid, args.queries, np.random.default_rng(args.seed))
        xmin, xmax, ymin, ymax = grid.extent
        out["maps"][map_name] = {"extent": [xmin, xmax, ymin, ymax], "resolution": grid.resolution,
                                 "queries": queries.tolist(),
                                 "planners": run_nav_map(grid, queries, params, args,
                                                         lambda label: progress(f"{map_name} {label}"))}
    out["load_average"]["end"] = load_average()
    out["wall_s"], out["cpu_s"] = time.perf_counter() - wall, time.process_time() - cpu
    return out


def stopping_rules(ompl: dict, ours: dict) -> str:
    """Where the two step planners' stopping rules differ (the worst-slip column follows from them)."""
    return (f"Where the sides differ: OMPL projects every state onto the stance constraint to "
            f"{ompl['tolerance'] * 1e3:g} mm (its default projection tolerance), ours stops once every sample's "
            f"stance-foot slack is within slack_fraction·ε = {ours['slack_fraction'] * ours['epsilon'] * 1e3:.2f} mm "
            f"(ε = {ours['epsilon'] * 1e3:g} mm). The worst-slip column shows these two stopping "
            "rules, not a difference in path quality.")


NAV_MARKER = "Navigation:"  # first line of the navigation part of the section


def load_text(load) -> str:
    """'load 0.5' or 'load 2.3 → 3.1' (older results recorded one value)."""
    if isinstance(load, dict):
        return f"load {load['start']:.1f} → {load['end']:.1f}"
    return f"load {load:.1f}"


def header(result) -> str:
    steps, nav = result["steps"], result["nav"]
    if steps["date"] == nav["date"] and steps["load_average"] == nav["load_average"]:
        when = f"{steps['date']}, {load_text(steps['load_average'])}"
    else:
        when = (f"steps {steps['date']}, {load_text(steps['load_average'])}; "
                f"navigation {nav['date']}, {load_text(nav['load_average'])}")
    return f"## baselines — ours vs OMPL 2.0.1, same problems, same run ({when})\n"


def steps_markdown(result) -> list[str]:
    steps = result["steps"]
    lines = [f"Machine: {result['machine']}; single process, one BLAS thread. Steps: scarab2 on "
             f"maps/gap_crossing.yaml, `legplan steps generate` sequence ({steps['configurations']} configurations), "
             "every pair of both bench/step_plan.py variants; ours = Bézier + LM (`legplan step plan` defaults), "
             f"OMPL = constrained RRT-Connect ({steps['ompl_params']['space']} space, "
             f"{steps['ompl_params']['time_budget']:g} s per step, seed {steps['ompl_params']['seed']} + step index), "
             "same inequality constraints (CoM, 2 cm clearance with the swing-foot relaxation, joint limits), "
             "both judged by the same dense check (1000 samples, pinocchio FK + FCL; every constraint, a step short "
             "on any fails; clearance shortfall = required − measured, ≤ 0 kept). Path terms of eq. (5) in "
             "x-space units: exact for the Bézier curve, finite differences of the dense samples for the OMPL "
             "polyline (roughness3 of a polyline grows as 1/h: not comparable, listed for completeness).\n",
             "| variant | planner | succeeded | median time [s] | mean time [s] | max time [s] | worst slip [mm] | "
             "worst CoM margin [mm] | worst clearance shortfall [mm] | median length | median ∫‖π''‖ | median ∫‖π'''‖ |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for variant, rows in steps["variants"].items():
        for who, row in rows.items():
            lines.append(f"| {variant} | {'ours (Bézier + LM)' if who == 'ours' else 'OMPL RRT-Connect'} | "
                         f"{row['succeeded']}/{row['planned']} | {row['median_time']:.3g} | {row['mean_time']:.3g} | "
                         f"{row['max_time']:.3g} | {row['worst_slip_mm']:.3g} | {row['worst_com_margin_mm']:.3g} | "
                         f"{row['worst_clearance_shortfall_mm']:.3g} | {row['median_length']:.3g} | "
                         f"{row['median_roughness2']:.3g} | {row['median_roughness3']:.3g} |")
    return lines + ["", stopping_rules(steps["ompl_params"], steps["ours_params"])]


def nav_differences(args_like: dict) -> str:
    """Where the navigation sides differ: what each stops at and what its trajectory is."""
    return ("Where the sides differ: our planners stop when the search reaches the goal state exactly "
            "(kinodynamic A* weighted, weight 2: cost within 2× the lattice optimum, up to 2.5× that after a "
            "restart; grid A* optimal on its 8-connected grid); OMPL RRT-Connect stops at its first solution, "
            "RRT* and PRM* use the whole budget (their median time ≈ the budget by design; 'first solution' is "
            "the time to compare), every geometric OMPL solution is then shortcut for up to "
            f"{args_like['simplify_time']:g} s (inside its time); the control planners stop at the first state "
            f"within {args_like['goal_tolerance']:g} of the goal state (m and m/s mixed, so they do not end at "
            "the goal exactly) or at the budget. Geometric OMPL and grid A* polylines stop at every vertex, the "
            "kinodynamic A* trajectory does not, so durations and efforts compare trajectories of different "
            "kinds. OMPL's budgets are wall-clock (timedPlannerTerminationCondition): on a loaded machine a "
            "budget buys fewer CPU seconds (CPU column), which can turn a control planner's late success into "
            "a failure.")


def nav_markdown(result) -> list[str]:
    from legplan.baselines.nav import NavBaselineParams

    nav = result["nav"]
    defaults = NavBaselineParams().as_dict()
    names = {"nav_30m": "maps/nav_30m.yaml", "warehouse (ROS)": "maps/ros/warehouse.yaml (ROS map_server, "
             "`legplan.terrain.importers.import_ros`)"}
    maps = "; ".join(f"{names.get(name, name)} {m['extent'][1] - m['extent'][0]:g} × "
                     f"{m['extent'][3] - m['extent'][2]:g} m at {m['resolution']:g} m"
                     for name, m in nav["maps"].items())
    counts = sorted({len(m["queries"]) for m in nav["maps"].values()})
    lines = [f"{NAV_MARKER} {maps}; on each map {'/'.join(map(str, counts))} seeded queries of bench/nav_search.py "
             f"(`sample_queries`, seed {nav['seed']}: the first of nav_search's queries on the same map), "
             f"jueying_mini (l1 = {nav['l1']:g} m, v_max = {nav['v_max']:g} m/s, "
             f"a_max = {nav['a_max']:g} m/s² per axis), every planner on the same queries in the same run "
             f"(OMPL as `legplan baseline nav`, query i with seed {nav['seed']} + i). Same hard constraint for all "
             "(NavGrid.blocked_at); geometric OMPL paths and grid A* use the same trapezoidal time parametrization "
             "(stop at each vertex); 'first solution' of RRT*/PRM* from a same-seed run stopped at the first "
             "solution (its time is inside the RRT*/PRM* query time). Time: wall time each planner reports; CPU: "
             "time.process_time around each query (all threads). Metrics: `legplan.nav.artefact.trajectory_metrics` "
             f"for every planner. Navigation part: {nav['wall_s'] / 60:.1f} min wall, {nav['cpu_s'] / 60:.1f} min CPU.\n",
             nav_differences(defaults) + "\n",
             "| map | planner | succeeded | median time [s] | max time [s] | median CPU [s] | "
             "median first solution [s] | median length [m] | median duration [s] | median effort ∫‖a‖² [m²/s³] | "
             "min clearance [m] | max |v| axis [m/s] | max |a| axis [m/s²] |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for map_name, entry in nav["maps"].items():
        for name, row in entry["planners"].items():
            lines.append(f"| {map_name} | {name} | {row['succeeded']}/{row['queries']} | {row['median_time']:.3g} | "
                         f"{row['max_time']:.3g} | {row['median_cpu_time']:.3g} | {row['median_first_solution']:.3g} | "
                         f"{row['median_length']:.3g} | {row['median_duration']:.3g} | {row['median_effort']:.3g} | "
                         f"{row['min_clearance']:.3g} | {row['max_speed_axis']:.3g} | {row['max_accel_axis']:.3g} |")
    failures = {(m, n): row["failures"] for m, e in nav["maps"].items() for n, row in e["planners"].items()
                if row["failures"]}
    if failures:
        lines += ["", "Failures: " + "; ".join(f"{m} {n}: {', '.join(f)}" for (m, n), f in failures.items()) + "."]
    return lines


def kept_part(part: str) -> list[str]:
    """The `part` ("steps" or "nav") text of the current BENCHMARKS.md section, without its header: kept as
    written by the run that measured it (its JSON entry may come from an older version of this script)."""
    begin, end = "<!-- bench:baselines -->", "<!-- /bench:baselines -->"
    text = BENCHMARKS.read_text()
    if begin not in text or end not in text:
        raise SystemExit(f"--only: no baselines section in {BENCHMARKS} to keep the {part} part of")
    lines = text.split(begin, 1)[1].split(end, 1)[0].strip().splitlines()[1:]
    split = next((i for i, line in enumerate(lines) if line.startswith(NAV_MARKER)), None)
    if split is None:
        raise SystemExit(f"--only: no line starting {NAV_MARKER!r} in the baselines section of {BENCHMARKS}")
    kept = lines[:split] if part == "steps" else lines[split:]
    while kept and not kept[0].strip():  # the blank line after the header, which header() ends with
        kept.pop(0)
    while kept and not kept[-1].strip():
        kept.pop()
    return kept


def markdown(result, only: str | None = None) -> list[str]:
    steps = steps_markdown(result) if only in (None, "steps") else kept_part("steps")
    nav = nav_markdown(result) if only in (None, "nav") else kept_part("nav")
    return [header(result)] + steps + [""] + nav


def previous_part(part: str) -> dict:
    """The `part` entry of bench/results/baselines.json, with the date and load of its run."""
    path = ROOT / "bench" / "results" / "baselines.json"
    if not path.exists():
        raise SystemExit(f"--only: {path} is missing, run both parts first")
    previous = json.loads(path.read_text())
    entry = previous[part]
    entry.setdefault("date", previous["date"])  # results before --only: one date and load for both parts
    entry.setdefault("load_average", previous["load_average"])
    return entry


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", type=Path)
    ap.add_argument("--steps", type=Path)
    ap.add_argument("--space", default="atlas", choices=("projected", "atlas", "tangent"))
    ap.add_argument("--step-budget", type=float, default=10.0)
    ap.add_argument("--queries", type=int, default=10)
    ap.add_argument("--nav-budget", type=float, default=1.0)
    ap.add_argument("--control-budget", type=float, default=10.0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", choices=("steps", "nav"),
                    help="run one part; keep the other's JSON entry and BENCHMARKS.md text")
    ap.add_argument("--no-append", action="store_true")
    args = ap.parse_args()

    def progress(label):
        return lambda done, total, message="": print(f"\r{label}: {done}/{total} {message}   ", end="",
                                                     file=sys.stderr)

    steps = run_steps(args, progress) if args.only in (None, "steps") else previous_part("steps")
    nav = run_nav(args, progress) if args.only in (None, "nav") else previous_part("nav")
    print(file=sys.stderr)
    result = {"date": max(steps["date"], nav["date"]), "machine": machine(), "seed": args.seed,
              "steps": steps, "nav": nav}
    lines = markdown(result, args.only)
    write_result("baselines", result)
    print("\n".join(lines))
    if not args.no_append:
        update_benchmarks("baselines", "\n".join(lines))


if __name__ == "__main__":
    main()
