"""Ours vs OMPL on the same problems, same machine, same run: step planning and navigation.

    .venv/bin/python bench/baselines.py [--map gap.h5 --steps steps.h5] [--step-budget 10]
        [--queries 10] [--nav-budget 1] [--control-budget 10] [--seed 0] [--no-append]

Steps: maps/gap_crossing.yaml with the scarab2 sequence of `legplan steps generate` (as
bench/step_plan.py builds it, or --map/--steps), both variants of bench/step_plan.py ('as
generated' pairs and 'whole swings'). Ours: `legplan.stepplan.plan_sequence` (Bézier + LM); OMPL:
constrained RRT-Connect (`legplan.baselines.step`, atlas space unless --space) with --step-budget
seconds per step. Both judged by the same dense check (worst stance-foot slip, CoM margin,
clearance shortfall with the swing-foot ramp; eq. (5) length and roughness — exact for the Bézier curve, finite differences of the
dense samples for the OMPL polyline, see legplan/baselines/step.py).

Navigation: maps/nav_30m.yaml, --queries seeded start/goal pairs of bench/nav_search.py
(`sample_queries`), jueying_mini limits. Ours: kinodynamic A* and grid A* (`legplan.nav.PLANNERS`);
OMPL: RRT-Connect, RRT*, PRM* (--nav-budget s) and KPIECE1 / RRT on the double integrator
(--control-budget s). Metrics from `legplan.nav.artefact.trajectory_metrics` for every planner.
Writes bench/results/baselines.json and updates its section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import importlib.util
import os
import sys
import tempfile
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")

import numpy as np  # noqa: E402
from common import ROOT, load_average, machine, update_benchmarks, write_result  # noqa: E402


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
        out = {"configurations": len(generated), "ompl_params": ompl.as_dict(),
               "ours_params": StepPlanParams().as_dict(), "variants": {}}
        for name, seq in (("as generated", generated), ("whole swings", step_bench.merge_swings(generated))):
            pairs = range(len(seq) - 1)
            ours = plan_sequence(seq, map_path, StepPlanParams(), pairs, progress=progress(f"ours {name}"))
            theirs = plan_sequence_baseline(seq, map_path, ompl, pairs, progress=progress(f"ompl {name}"))
            out["variants"][name] = {"ours": step_rows(ours), "ompl": step_rows(theirs)}
    return out


def nav_rows(results, planning_times, first_times, grid) -> dict:
    from legplan.nav.artefact import trajectory_metrics

    metrics = [trajectory_metrics(r.trajectory, grid) for r in results]
    ok = [m for r, m in zip(results, metrics) if r.success]
    return {"queries": len(results), "succeeded": len(ok),
            "median_time": _median(planning_times), "max_time": float(max(planning_times)),
            "median_first_solution": _median(first_times),
            "median_length": _median([m["path_length"] for m in ok]),
            "median_duration": _median([m["duration"] for m in ok]),
            "median_effort": _median([m["effort"] for m in ok]),
            "min_clearance": min((m["min_clearance"] for m in ok), default=float("nan")),
            "max_speed_axis": max((m["max_speed_axis"] for m in ok), default=float("nan")),
            "max_accel_axis": max((m["max_accel_axis"] for m in ok), default=float("nan")),
            "failures": sorted({r.reason for r in results if not r.success})}


def run_nav(args, progress) -> dict:
    from legplan.baselines.nav import NavBaselineParams, plan_queries
    from legplan.nav import PLANNERS, NavGrid, NavParams
    from legplan.robots import load_robot
    from legplan.terrain import build_map

    navigation = load_robot("jueying_mini").navigation
    params = NavParams.for_robot(navigation)
    grid = NavGrid.from_terrain(build_map(ROOT / "maps" / "nav_30m.yaml"), lethal_radius=navigation.inscribed_radius)
    queries = bench_module("nav_search").sample_queries(grid, args.queries, np.random.default_rng(args.seed))
    out = {"queries": queries.tolist(), "l1": grid.l1, "v_max": params.v_max, "a_max": params.a_max, "planners": {}}
    for name in ("kinoastar", "astar"):
        results = [PLANNERS[name](grid, q[:4], q[4:], params) for q in queries]
        times = [r.planning_time for r in results]
        out["planners"][f"ours: {name}"] = nav_rows(results, times, [t if r.success else None
                                                                    for r, t in zip(results, times)], grid)
    for planner in ("rrtconnect", "rrtstar", "prmstar", "kpiece-control", "rrt-control"):
        budget = args.control_budget if planner.endswith("control") else args.nav_budget
        settings = NavBaselineParams(planner=planner, time_budget=budget, seed=args.seed, v_max=params.v_max,
                                     a_max=params.a_max)
        outcomes = plan_queries(grid, queries, settings, progress(f"ompl {planner}"))
        out["planners"][f"OMPL {planner} ({budget:g} s)"] = nav_rows(
            [o.result for o in outcomes], [o.result.planning_time for o in outcomes],
            [o.time_to_first_solution for o in outcomes], grid)
    return out


def stopping_rules(ompl: dict, ours: dict) -> str:
    """Where the two step planners' stopping rules differ (the worst-slip column follows from them)."""
    return (f"Where the sides differ: OMPL projects every state onto the stance constraint to "
            f"{ompl['tolerance'] * 1e3:g} mm (its default projection tolerance), ours stops once every sample's "
            f"stance-foot slack is within slack_fraction·ε = {ours['slack_fraction'] * ours['epsilon'] * 1e3:.2f} mm "
            f"(ε = {ours['epsilon'] * 1e3:g} mm). The worst-slip column shows these two stopping "
            "rules, not a difference in path quality.")


def markdown(result) -> list[str]:
    date, steps, nav = result["date"], result["steps"], result["nav"]
    lines = [f"## baselines — ours vs OMPL 2.0.1, same problems, same run ({date}, load {result['load_average']:.1f})\n",
             f"Machine: {result['machine']}; single process, one BLAS thread. Steps: scarab2 on "
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
    lines += ["", stopping_rules(steps["ompl_params"], steps["ours_params"])]
    lines += ["", f"Navigation: maps/nav_30m.yaml, {len(nav['queries'])} seeded queries of bench/nav_search.py "
              f"(seed {result['seed']}), jueying_mini (l1 = {nav['l1']:g} m, v_max = {nav['v_max']:g} m/s, "
              f"a_max = {nav['a_max']:g} m/s² per axis). Same hard constraint for all (NavGrid.blocked_at); "
              "geometric OMPL paths and grid A* use the same trapezoidal time parametrization (stop at each vertex); "
              "'first solution' of RRT*/PRM* from a same-seed run stopped at the first solution. Metrics: "
              "`legplan.nav.artefact.trajectory_metrics` for every planner.\n",
              "| planner | succeeded | median time [s] | max time [s] | median first solution [s] | "
              "median length [m] | median duration [s] | median effort ∫‖a‖² [m²/s³] | min clearance [m] | "
              "max |v| axis [m/s] | max |a| axis [m/s²] |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for name, row in nav["planners"].items():
        lines.append(f"| {name} | {row['succeeded']}/{row['queries']} | {row['median_time']:.3g} | "
                     f"{row['max_time']:.3g} | {row['median_first_solution']:.3g} | {row['median_length']:.3g} | "
                     f"{row['median_duration']:.3g} | {row['median_effort']:.3g} | {row['min_clearance']:.3g} | "
                     f"{row['max_speed_axis']:.3g} | {row['max_accel_axis']:.3g} |")
    return lines


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
    ap.add_argument("--no-append", action="store_true")
    args = ap.parse_args()

    def progress(label):
        return lambda done, total, message="": print(f"\r{label}: {done}/{total} {message}   ", end="",
                                                     file=sys.stderr)

    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "load_average": load_average(),
              "seed": args.seed,
              "steps": run_steps(args, progress), "nav": run_nav(args, progress)}
    print(file=sys.stderr)
    write_result("baselines", result)
    lines = markdown(result)
    print("\n".join(lines))
    if not args.no_append:
        update_benchmarks("baselines", "\n".join(lines))


if __name__ == "__main__":
    main()
