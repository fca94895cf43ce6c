"""Nav search front ends: kinodynamic A* vs grid A* on maps/nav_30m.yaml and the ROS warehouse map.

20 seeded start/goal pairs per map (free cells with clearance ≥ l1 + 0.15 m, at least a third of the
map's diagonal apart, from `numpy.random.default_rng(seed)`), both planners with default
`NavParams.for_robot(jueying_mini)`. Per planner: success rate, median and max planning time,
median expansions, median time per expansion (planning time / expansions per query), median
duration and effort of the successful trajectories. Each query is run `--repeats` times and the
median planning time is kept. The reference of the ratio column is grid A*.
Per-query time per expansion includes setup and the one-shot attempts near the goal, which
dominate short searches; the steady-state cost of one expansion is measured separately: the first
5 queries searched with the one-shot off, weight 1 and exactly `STEADY_EXPANSIONS` expansions.
Writes bench/results/nav_search.json and appends rows to BENCHMARKS.md.
    .venv/bin/python bench/nav_search.py [--queries 20] [--repeats 3] [--seed 0] [--no-append]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import platform
import statistics
from pathlib import Path

import numpy as np

from legplan.nav import PLANNERS, NavGrid, NavParams
from legplan.robots import load_robot
from legplan.terrain import build_map
from legplan.terrain.importers import import_ros

ROOT = Path(__file__).resolve().parents[1]
MAPS = {"nav_30m": lambda: build_map(ROOT / "maps" / "nav_30m.yaml"),
        "warehouse (ROS)": lambda: import_ros(ROOT / "maps" / "ros" / "warehouse.yaml")}


def cpu_model() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return "unknown CPU"


def sample_queries(grid: NavGrid, count: int, rng: np.random.Generator) -> np.ndarray:
    iy, ix = np.nonzero(grid.distance >= grid.l1 + 0.15)
    free = grid.cell_center(iy, ix)
    free = free[~grid.blocked_at(free)]
    xmin, xmax, ymin, ymax = grid.extent
    min_gap = np.hypot(xmax - xmin, ymax - ymin) / 3
    queries = []
    while len(queries) < count:
        a, b = free[rng.integers(len(free), size=2)]
        if np.linalg.norm(a - b) >= min_gap:
            queries.append([a[0], a[1], 0.0, 0.0, b[0], b[1], 0.0, 0.0])
    return np.array(queries)


STEADY_EXPANSIONS = 3000


def steady_expansion_cost(grid, queries, params, repeats) -> float:
    """Median µs per expansion of the bare search loop (no one-shot, fixed expansion count)."""
    bare = params.replace(oneshot_radius=0.0, weight=1.0, max_expansions=STEADY_EXPANSIONS)
    costs = []
    for query in queries[:5]:
        runs = [PLANNERS["kinoastar"](grid, query[:4], query[4:], bare) for _ in range(repeats)]
        costs.append(statistics.median(1e6 * r.planning_time / r.expansions for r in runs))
    return statistics.median(costs)


def run_planner(name, grid, queries, params, repeats):
    if name == "astar":  # grid A* is complete within the map's cell count
        params = params.replace(max_expansions=grid.shape[0] * grid.shape[1])
    rows = []
    for query in queries:
        results = [PLANNERS[name](grid, query[:4], query[4:], params) for _ in range(repeats)]
        result = results[0]
        time_s = statistics.median(r.planning_time for r in results)
        trajectory = result.trajectory
        rows.append({"success": result.success, "reason": result.reason,
                     "expansions": result.expansions, "planning_time": time_s,
                     "time_per_expansion": time_s / max(result.expansions, 1),
                     "duration": trajectory.duration if trajectory else None,
                     "effort": trajectory.effort() if trajectory else None})
    ok = [row for row in rows if row["success"]]

    def median(key, source):
        values = [row[key] for row in source]
        return statistics.median(values) if values else float("nan")

    return {"success_rate": len(ok) / len(rows),
            "median_planning_time_s": median("planning_time", rows),
            "max_planning_time_s": max(row["planning_time"] for row in rows),
            "median_expansions": median("expansions", rows),
            "median_time_per_expansion_us": 1e6 * median("time_per_expansion", rows),
            "median_duration_s": median("duration", ok), "median_effort": median("effort", ok),
            "failures": sorted({row["reason"] for row in rows if not row["success"]}),
            "queries": rows}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--queries", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-expansions", type=int, default=30000,
                        help="Expansion limit of kinoastar (keeps failing queries bounded); grid A* "
                             "may expand every cell.")
    parser.add_argument("--no-append", action="store_true")
    args = parser.parse_args()
    navigation = load_robot("jueying_mini").navigation
    params = NavParams.for_robot(navigation).replace(max_expansions=args.max_expansions)
    date = datetime.date.today().isoformat()
    machine = {"cpu": cpu_model(), "arch": platform.machine(), "cores": os.cpu_count(),
               "load_average_start": os.getloadavg()}
    results = {}
    for map_name, build in MAPS.items():
        grid = NavGrid.from_terrain(build(), lethal_radius=navigation.inscribed_radius)
        queries = sample_queries(grid, args.queries, np.random.default_rng(args.seed))
        results[map_name] = {planner: run_planner(planner, grid, queries, params, args.repeats)
                             for planner in ("kinoastar", "astar")}
        steady = steady_expansion_cost(grid, queries, params, args.repeats)
        results[map_name]["kinoastar"]["steady_time_per_expansion_us"] = steady
        print(f"{map_name:16s} kinoastar steady-state {steady:.1f} µs/expansion")
        for planner, entry in results[map_name].items():
            print(f"{map_name:16s} {planner:9s} success {entry['success_rate']:.0%}  "
                  f"time median {entry['median_planning_time_s']:.3f} s max "
                  f"{entry['max_planning_time_s']:.3f} s  expansions {entry['median_expansions']:.0f}"
                  f"  {entry['median_time_per_expansion_us']:.1f} µs/expansion  "
                  f"T {entry['median_duration_s']:.1f} s  J {entry['median_effort']:.2f}")
    machine["load_average_end"] = os.getloadavg()
    out = {"date": date, "machine": machine, "seed": args.seed, "repeats": args.repeats,
           "params": params.as_dict(), "maps": results}
    path = ROOT / "bench" / "results" / "nav_search.json"
    path.write_text(json.dumps(out, indent=2, default=float))
    if args.no_append:
        return
    lines = [f"\n## nav search: kinodynamic A* vs grid A* ({date}, {machine['cpu']}, "
             f"{machine['arch']}, load avg {machine['load_average_start'][0]:.1f})",
             f"{args.queries} seeded start/goal pairs per map (seed {args.seed}), median of "
             f"{args.repeats} runs per query, default NavParams (weight {params.weight}, "
             f"μ={params.mu}, τ={params.tau} s, kinoastar expansion limit {params.max_expansions}). Ratio: median planning time vs grid A*. "
             "µs/expansion: median over queries of time/expansions (kinoastar: in brackets the "
             f"steady-state search loop, one-shot off, {STEADY_EXPANSIONS} expansions).", "",
             "| map | planner | success | median time (s) | max time (s) | ratio | median "
             "expansions | µs/expansion | median T (s) | median effort J |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for map_name, entry in results.items():
        reference = entry["astar"]["median_planning_time_s"]
        for planner, row in entry.items():
            steady = row.get("steady_time_per_expansion_us")
            per_expansion = f"{row['median_time_per_expansion_us']:.1f}" + \
                (f" ({steady:.1f})" if steady is not None else "")
            lines.append(f"| {map_name} | {planner} | {row['success_rate']:.0%} | "
                         f"{row['median_planning_time_s']:.3f} | {row['max_planning_time_s']:.3f} | "
                         f"{row['median_planning_time_s'] / reference:.2f}× | "
                         f"{row['median_expansions']:.0f} | "
                         f"{per_expansion} | "
                         f"{row['median_duration_s']:.1f} | {row['median_effort']:.2f} |")
    with open(ROOT / "BENCHMARKS.md", "a") as handle:
        handle.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
