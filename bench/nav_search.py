"""Nav search front ends: kinodynamic A* vs grid A* on maps/nav_30m.yaml and the ROS warehouse map.

20 seeded start/goal pairs per map (free cells with clearance ≥ l1 + 0.15 m, at least a third of the
map's diagonal apart, from `numpy.random.default_rng(seed)`), both planners with default
`NavParams.for_robot(jueying_mini)`, plus kinoastar with each `--variant KEY=VALUE[,KEY=VALUE]`
override. Per planner: success rate, median and max planning time, median expansions, median time
per expansion (planning time / expansions per query), median duration and effort of the successful
trajectories. Each query is run `--repeats` times and the median planning time is kept. The
reference of the ratio column is grid A*.
Per-query time per expansion includes setup and the one-shot attempts near the goal, which
dominate short searches; the steady-state cost of one expansion is measured separately: the first
5 queries searched with the one-shot off, weight 1 and exactly `STEADY_EXPANSIONS` expansions.
`--before REV` first runs the same measurements on the `legplan` package of git revision REV
(exported with `git archive`, first on PYTHONPATH of a child process; same robot files and maps)
and adds a before/after table.
Writes bench/results/nav_search.json and replaces the nav_search section of BENCHMARKS.md.
    flock /tmp/legplan-bench.lock .venv/bin/python bench/nav_search.py [--queries 20] [--repeats 3]
        [--seed 0] [--before REV] [--variant vel_res=0.4] [--no-append]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import statistics
import subprocess
import sys
import tarfile
import tempfile
from collections import Counter
from io import BytesIO
from pathlib import Path

import numpy as np

from common import ROOT, load_average, machine, update_benchmarks, write_result

from legplan.nav import PLANNERS, NavGrid, NavParams
from legplan.robots import load_robot
from legplan.terrain import build_map
from legplan.terrain.importers import import_ros

MAPS = {"nav_30m": lambda: build_map(ROOT / "maps" / "nav_30m.yaml"),
        "warehouse (ROS)": lambda: import_ros(ROOT / "maps" / "ros" / "warehouse.yaml")}
STEADY_EXPANSIONS = 3000


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
            "failures": dict(Counter(row["reason"] for row in rows if not row["success"])),
            "queries": rows}


def parse_variant(text: str) -> dict[str, str]:
    return dict(item.split("=", 1) for item in text.split(","))


def measure(args) -> dict:
    """{map: {planner label: summary}} for the legplan package this process imported."""
    navigation = load_robot("jueying_mini").navigation
    params = NavParams.for_robot(navigation).replace(max_expansions=args.max_expansions)
    planners = [("kinoastar", "kinoastar", params), ("astar", "astar", params)] + \
        [(f"kinoastar ({variant})", "kinoastar", params.with_overrides(parse_variant(variant)))
         for variant in args.variant]
    results = {}
    for map_name, build in MAPS.items():
        grid = NavGrid.from_terrain(build(), lethal_radius=navigation.inscribed_radius)
        queries = sample_queries(grid, args.queries, np.random.default_rng(args.seed))
        results[map_name] = {label: run_planner(planner, grid, queries, chosen, args.repeats)
                             for label, planner, chosen in planners}
        steady = steady_expansion_cost(grid, queries, params, args.repeats)
        results[map_name]["kinoastar"]["steady_time_per_expansion_us"] = steady
        for label, entry in results[map_name].items():
            print(f"{map_name:16s} {label:24s} success {entry['success_rate']:.0%}  time median "
                  f"{entry['median_planning_time_s']:.3f} s max {entry['max_planning_time_s']:.3f}"
                  f" s  expansions {entry['median_expansions']:.0f}  "
                  f"{entry['median_time_per_expansion_us']:.1f} µs/expansion", file=sys.stderr)
        print(f"{map_name:16s} kinoastar steady-state {steady:.1f} µs/expansion", file=sys.stderr)
    return results


def measure_revision(revision: str, args) -> dict:
    """`measure` in a child process that imports the `legplan` package of git `revision`."""
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", revision, "legplan"],
                             check=True, capture_output=True).stdout
    with tempfile.TemporaryDirectory() as folder:
        with tarfile.open(fileobj=BytesIO(archive)) as tar:
            tar.extractall(folder, filter="data")
        out = Path(folder) / "result.json"
        command = [sys.executable, __file__, "--queries", str(args.queries), "--repeats",
                   str(args.repeats), "--seed", str(args.seed), "--max-expansions",
                   str(args.max_expansions), "--result-only", str(out)]
        env = dict(os.environ, LEGPLAN_ROBOTS=str(ROOT / "robots"), PYTHONPATH=os.pathsep.join(
            [folder] + [p for p in [os.environ.get("PYTHONPATH")] if p]))
        subprocess.run(command, check=True, env=env)
        return json.loads(out.read_text())


def table(results: dict) -> list[str]:
    lines = ["| map | planner | success | median time (s) | max time (s) | ratio | median "
             "expansions | µs/expansion (steady) | median T (s) | median effort J |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    failures = []
    for map_name, entry in results.items():
        reference = entry["astar"]["median_planning_time_s"]
        for label, row in entry.items():
            steady = row.get("steady_time_per_expansion_us")
            per_expansion = f"{row['median_time_per_expansion_us']:.1f}" + \
                (f" ({steady:.1f})" if steady is not None else "")
            lines.append(f"| {map_name} | {label} | {row['success_rate']:.0%} | "
                         f"{row['median_planning_time_s']:.3f} | "
                         f"{row['max_planning_time_s']:.3f} | "
                         f"{row['median_planning_time_s'] / reference:.2f}× | "
                         f"{row['median_expansions']:.0f} | {per_expansion} | "
                         f"{row['median_duration_s']:.1f} | {row['median_effort']:.2f} |")
            failures += [f"{map_name} {label}: {count}× {reason}"
                         for reason, count in row["failures"].items()]
    return lines + ["", "Failures: " + ("; ".join(failures) if failures else "none") + ". Rows "
                    "'kinoastar (KEY=VALUE)' are the same search with those NavParams overrides."]


def before_after(before: dict, after: dict, revision: str) -> list[str]:
    lines = [f"Before/after, kinoastar with default parameters: before = commit {revision}, run "
             "by this script in the same invocation right before the current code.", "",
             "| map | steady µs/expansion | per-query µs/expansion (median) | success | median "
             "time (s) | max time (s) | median expansions |", "|---|---|---|---|---|---|---|"]
    for map_name, entry in after.items():
        old, new = before[map_name]["kinoastar"], entry["kinoastar"]
        steady_old, steady_new = (row["steady_time_per_expansion_us"] for row in (old, new))
        lines.append(
            f"| {map_name} | {steady_old:.1f} → {steady_new:.1f} "
            f"({steady_old / steady_new:.1f}×) | "
            f"{old['median_time_per_expansion_us']:.1f} → {new['median_time_per_expansion_us']:.1f}"
            f" | {old['success_rate']:.0%} → {new['success_rate']:.0%} | "
            f"{old['median_planning_time_s']:.3f} → {new['median_planning_time_s']:.3f} | "
            f"{old['max_planning_time_s']:.3f} → {new['max_planning_time_s']:.3f} | "
            f"{old['median_expansions']:.0f} → {new['median_expansions']:.0f} |")
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--queries", type=int, default=20)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--max-expansions", type=int, default=NavParams().max_expansions,
                        help="Expansion limit of kinoastar (default: NavParams' own); grid A* may "
                             "expand every cell.")
    parser.add_argument("--variant", action="append", default=[],
                        help="extra kinoastar row with these NavParams overrides, KEY=VALUE[,...]")
    parser.add_argument("--before", metavar="REV", help="also measure git revision REV first")
    parser.add_argument("--result-only", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--no-append", action="store_true", help="do not update BENCHMARKS.md")
    args = parser.parse_args()
    if args.result_only:
        args.result_only.write_text(json.dumps(measure(args), default=float))
        return
    load_start = load_average()
    before = measure_revision(args.before, args) if args.before else None
    results = measure(args)
    params = NavParams.for_robot(load_robot("jueying_mini").navigation).replace(
        max_expansions=args.max_expansions)
    out = {"date": datetime.date.today().isoformat(), "machine": machine(),
           "load_average": {"start": load_start, "end": load_average()}, "seed": args.seed,
           "queries": args.queries, "repeats": args.repeats, "params": params.as_dict(),
           "variants": args.variant, "maps": results}
    if before is not None:
        out["before"] = {"revision": args.before, "maps": before}
    write_result("nav_search", out)
    if args.no_append:
        return
    lines = [f"## nav search: kinodynamic A* vs grid A* ({out['date']}, {out['machine']}, "
             f"load avg {load_start:.1f} → {out['load_average']['end']:.1f})", "",
             f"{args.queries} seeded start/goal pairs per map (seed {args.seed}), median of "
             f"{args.repeats} runs per query, default NavParams (weight {params.weight}, "
             f"μ={params.mu}, τ={params.tau} s, pos_res {params.pos_res} m, vel_res "
             f"{params.vel_res} m/s, one-shot radius {params.oneshot_radius} m, kinoastar "
             f"expansion limit {params.max_expansions}). Ratio: median planning time vs grid A*. "
             "µs/expansion: median over queries of time/expansions (kinoastar: in brackets the "
             f"steady-state search loop, one-shot off, weight 1, {STEADY_EXPANSIONS} expansions, "
             "median of the first 5 queries).", ""] + table(results)
    if before is not None:
        lines += [""] + before_after(before, results, args.before)
    update_benchmarks("nav_search", "\n".join(lines))


if __name__ == "__main__":
    main()
