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

`--scale N` adds the nav_scale part (issue 19): synthetic street maps of 256², 512² and 1024² cells
at 0.2 m (51 m to 205 m across) from a seeded generator (`street_map`: a jittered grid of streets
5–13 cells wide, 30 % of the street segments closed, half of those leaving a 1-cell crack, 1–2-cell
alleys, a few plazas) — stand-ins for the MovingAI street maps, which this machine cannot download.
Each map is written as a MovingAI `.map` with a `.scen` of its N queries (`--scale-dir`, default a
new temporary folder; regenerated from the seed, so not kept in the repository)
and read back through `legplan.terrain.importers.import_movingai`, so public benchmark files run
the same way. Queries as above (seeded, at least a third of the diagonal apart). Planners: grid A*,
the kinodynamic A* with the defaults, and "kinoastar (old)" = the previous defaults (straight-line
LQMT heuristic only, fixed 200,000-expansion limit), all in the same run, one run per query; peak
traced memory (tracemalloc) of each planner on the map's longest query (not for the old defaults,
whose failures each run 200,000 expansions; issue 19 measured about 350 MB for them).
    flock /tmp/legplan-bench.lock .venv/bin/python bench/nav_search.py [--queries 20] [--repeats 3]
        [--seed 0] [--before REV] [--variant vel_res=0.4] [--scale 5] [--no-append]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import resource
import statistics
import subprocess
import sys
import tarfile
import tempfile
import time
import tracemalloc
from collections import Counter
from io import BytesIO
from pathlib import Path

import numpy as np

from common import ROOT, load_average, machine, update_benchmarks, write_result

from legplan.nav import PLANNERS, NavGrid, NavParams
from legplan.nav.queries import read_scen
from legplan.robots import load_robot
from legplan.terrain import build_map, save_map
from legplan.terrain.importers import import_movingai, import_ros

MAPS = {"nav_30m": lambda: build_map(ROOT / "maps" / "nav_30m.yaml"),
        "warehouse (ROS)": lambda: import_ros(ROOT / "maps" / "ros" / "warehouse.yaml")}
STEADY_EXPANSIONS = 3000
SCALE_SIZES = (256, 512, 1024)  # cells per side at SCALE_RESOLUTION
SCALE_RESOLUTION = 0.2  # m
OLD_DEFAULTS = {"geodesic_bound": "0", "max_expansions": "200000"}  # before issue 19
OMPL_SCALE = ("rrtconnect", "rrtstar")  # OMPL rows of nav_scale (1 s budget each)
RESTART_NOTE = (
    "Restart stage budget (`kinoastar.STAGE_EXPANSIONS_PER_STEP`): 10 expansions per route step, chosen "
    "in a side run (5 queries each on 256² and 512² street maps, load 5–7): 20 → 10 → 5 per step gave "
    "max expansions 12406 → 7006 → 5606 (256²) and 18672 → 11085 → 6085 (512²), the larger restarts "
    "costing effort on some queries (J 11.6 → 15.4).")
SCALE_NOTES = (
    "Why the former opt-in `geodesic_bound` (T ≥ κ·T_route, combined with the straight-line bound "
    "T_s = max_d |Δ_d| / v_max by max) barely helped: κ = v_max τ / ((⌊v_max τ / R⌋ + 1) R) keeps "
    "it consistent but is 0.75 at R = 0.2 m, so along every street that runs across the goal's "
    "dominant axis the max picks T_s, which is flat there — h had plateaus and weighted A* flooded "
    "them in position and velocity; its BFS also went through 1–2-cell cracks the robot cannot "
    "pass. The default bound T_s + κ·(T_route − T_s) (heuristic.GeodesicTimeBound) is as "
    "consistent and falls along every route. Development run (earlier generator version, 6 queries "
    "on a 256² map, 20,000-expansion cap, load 14): κ·T_route by max solved 1/6 even at weight 5, "
    "the default form 6/6 at weight 2 (1.4k–5k expansions), an inconsistent κ = 1 form 6/6 with "
    "0.5k–1.2k expansions but without the weight's suboptimality bound, so not used. "
    "Time ratio: median planning time / grid A*'s on the same map (issue 19's target: ≤ 2× for "
    "kinoastar). OMPL rows: geometric RRT-Connect and RRT* of `baseline nav` (1 s budget; RRT* "
    "uses all of it), same hard constraint, their polylines timed like grid A*'s (stop at every "
    "vertex), so their T and effort are not comparable with kinoastar's smooth trajectories; "
    "'expansions' are their motion checks; peak memory not measured (OMPL allocates in C++, "
    "which tracemalloc does not see). " + RESTART_NOTE)


def sample_queries(grid: NavGrid, count: int, rng: np.random.Generator) -> np.ndarray:
    iy, ix = np.nonzero(grid.distance >= grid.l1 + 0.15)
    free = grid.frame.cell_center(iy, ix)
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


def run_planner(name, grid, queries, params, repeats, plan=None):
    """Summary of planner `name` (or the function `plan`) over `queries`: wall planning time as the
    planner reports it and CPU time (time.process_time around the call), medians over repeats."""
    plan = plan or PLANNERS[name]
    rows = []
    for query in queries:
        results, cpu = [], []
        for _ in range(repeats):
            clock = time.process_time()
            results.append(plan(grid, query[:4], query[4:], params))
            cpu.append(time.process_time() - clock)
        result = results[0]
        time_s = statistics.median(r.planning_time for r in results)
        trajectory = result.trajectory
        rows.append({"success": result.success, "reason": result.reason,
                     "expansions": result.expansions, "planning_time": time_s,
                     "cpu_time": statistics.median(cpu),
                     "time_per_expansion": time_s / max(result.expansions, 1),
                     "duration": trajectory.duration if trajectory else None,
                     "length": trajectory.path_length() if trajectory else None,
                     "effort": trajectory.effort() if trajectory else None})
    ok = [row for row in rows if row["success"]]

    def median(key, source):
        values = [row[key] for row in source]
        return statistics.median(values) if values else float("nan")

    return {"success_rate": len(ok) / len(rows),
            "median_planning_time_s": median("planning_time", rows),
            "max_planning_time_s": max(row["planning_time"] for row in rows),
            "median_cpu_time_s": median("cpu_time", rows),
            "median_expansions": median("expansions", rows),
            "median_time_per_expansion_us": 1e6 * median("time_per_expansion", rows),
            "median_duration_s": median("duration", ok), "median_effort": median("effort", ok),
            "failures": dict(Counter(row["reason"] for row in rows if not row["success"])),
            "queries": rows}


def street_map(n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, n) occupancy (True = obstacle) of a synthetic street map, row 0 = smallest y."""
    occupancy = np.ones((n, n), bool)

    def streets():
        position, out = 0, []
        while (position := position + int(rng.integers(40, 110))) <= n - 20:
            out.append((position, int(rng.integers(5, 14))))
        return out

    columns, rows = [(3, 10)] + streets() + [(n - 13, 10)], [(3, 10)] + streets() + [(n - 13, 10)]
    for x, width in columns:
        occupancy[3:-3, x:x + width] = False
    for y, width in rows:
        occupancy[y:y + width, 3:-3] = False
    for along, across, flip in ((rows, columns, False), (columns, rows, True)):
        for (a, a_width), (b, _) in zip(along, along[1:]):
            for c, width in across[1:-1]:
                if rng.random() < 0.3 and b - (a + a_width) > 4:  # close this segment
                    d = int(rng.integers(a + a_width, b - 3))
                    block = (slice(d, d + 3), slice(c, c + width))
                    occupancy[block[::-1] if flip else block] = True
                    if rng.random() < 0.5:  # a crack one cell wide
                        crack = (slice(d, d + 3), c + width // 2)
                        occupancy[crack[::-1] if flip else crack] = False
    for _ in range(n // 12):  # alleys 1-2 cells wide
        at, width = int(rng.integers(5, n - 5)), int(rng.integers(1, 3))
        lo, hi = np.sort(rng.integers(5, n - 5, 2))
        alley = (slice(lo, hi), slice(at, at + width))
        occupancy[alley[::-1] if rng.random() < 0.5 else alley] = False
    for _ in range(max(1, n // 256)):  # plazas
        cx, cy = rng.integers(30, n - 30, 2)
        r = int(rng.integers(10, 25))
        occupancy[cy - r:cy + r, cx - r:cx + r] = False
    occupancy[:3] = occupancy[-3:] = occupancy[:, :3] = occupancy[:, -3:] = True
    return occupancy


def write_movingai(folder: Path, name: str, occupancy: np.ndarray, queries: np.ndarray) -> Path:
    """`name.map` (first row = largest y) and `name.map.scen` (start/goal columns and rows counted
    from the top row, bucket = straight distance // 4 cells, optimal length left 0: unknown)."""
    ny, nx = occupancy.shape
    path = folder / f"{name}.map"
    body = ["".join("@" if cell else "." for cell in row) for row in occupancy[::-1]]
    path.write_text("\n".join(["type octile", f"height {ny}", f"width {nx}", "map"] + body) + "\n")
    cells = np.floor(queries[:, [0, 1, 4, 5]] / SCALE_RESOLUTION).astype(int)
    lines = ["version 1"] + [
        f"{int(np.hypot(gx - sx, gy - sy)) // 4}\t{path.name}\t{nx}\t{ny}\t{sx}\t{ny - 1 - sy}\t"
        f"{gx}\t{ny - 1 - gy}\t0" for sx, sy, gx, gy in cells.tolist()]
    (folder / f"{name}.map.scen").write_text("\n".join(lines) + "\n")
    return path


def peak_memory_mb(planner, grid, query, params) -> float:
    """Peak traced MB of one query on a fresh copy of `grid` (its BFS graph cache included)."""
    fresh = NavGrid(grid.costmap, grid.distance, grid.l1, grid.origin, grid.resolution)
    tracemalloc.start()
    PLANNERS[planner](fresh, query[:4], query[4:], params)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    return peak / 2**20


def measure_scale(args) -> tuple[dict, dict]:
    """{map: {planner: summary + peak memory}} on the synthetic street maps (module doc), and the
    start-up times of `measure_startup` on the smallest one."""
    navigation = load_robot("jueying_mini").navigation
    params = NavParams.for_robot(navigation)
    planners = [("astar", "astar", params, None), ("kinoastar", "kinoastar", params, None),
                ("kinoastar (old)", "kinoastar", params.with_overrides(OLD_DEFAULTS), None)]
    planners += [(f"OMPL {name} (1 s)", name, None, ompl_planner(name, params)) for name in OMPL_SCALE]
    folder = args.scale_dir or Path(tempfile.mkdtemp(prefix="nav_scale_"))
    folder.mkdir(parents=True, exist_ok=True)
    print(f"nav_scale maps and scenarios in {folder}", file=sys.stderr)
    results = {}
    for n in SCALE_SIZES:
        rng = np.random.default_rng(args.seed + n)
        occupancy = street_map(n, rng)
        name = f"streets_{n}"
        path = write_movingai(folder, name, occupancy, np.zeros((0, 8)))
        terrain = import_movingai(path, SCALE_RESOLUTION)
        grid = NavGrid.from_terrain(terrain, lethal_radius=navigation.inscribed_radius)
        if n == SCALE_SIZES[0]:
            save_map(terrain, folder / f"{name}.h5")
            startup = measure_startup(folder / f"{name}.h5", grid)
        write_movingai(folder, name, occupancy, sample_queries(grid, args.scale, rng))
        queries = read_scen(folder / f"{name}.map.scen", grid)
        label = f"streets {n}² ({n * SCALE_RESOLUTION:.0f} m)"
        longest = queries[np.argmax(np.hypot(*(queries[:, 4:6] - queries[:, :2]).T))]
        results[label] = {}
        for planner_label, planner, chosen, plan in planners:
            entry = run_planner(planner, grid, queries, chosen, 1, plan)
            entry["peak_memory_mb"] = float("nan") if plan or planner_label.endswith("(old)") else \
                peak_memory_mb(planner, grid, longest, chosen)
            results[label][planner_label] = entry
            print(f"{label:24s} {planner_label:16s} success {entry['success_rate']:.0%} "
                  f"time median "
                  f"{entry['median_planning_time_s']:.3f} s max {entry['max_planning_time_s']:.3f} "
                  f"s expansions {entry['median_expansions']:.0f} peak "
                  f"{entry['peak_memory_mb']:.0f} MB", file=sys.stderr, flush=True)
    return results, startup


def ompl_planner(name: str, params: NavParams):
    """An OMPL geometric planner (`legplan.baselines.nav`, 1 s budget, seed = query index order)
    with the nav search's signature, timed like grid A* (trapezoid, stop at every vertex)."""
    from legplan.baselines.nav import NavBaselineParams, plan_baseline

    settings = NavBaselineParams(planner=name, time_budget=1.0, v_max=params.v_max, a_max=params.a_max)
    seeds = iter(range(10**6))
    return lambda grid, start, goal, _: plan_baseline(grid, start, goal, settings, next(seeds)).result


def measure_startup(map_path: Path, grid: NavGrid, runs: int = 5) -> dict:
    """Median wall and CPU seconds (the child's user + system time) of `legplan --help` and of a
    trivial `nav search` (two free cells 1 m apart) on `map_path`, each in a fresh process."""
    free = grid.frame.cell_center(*np.nonzero(grid.distance >= grid.l1 + 0.15))
    free = free[~grid.blocked_at(free)]
    a = free[0]
    b = free[np.argmin(np.abs(np.hypot(*(free - a).T) - 1.0))]
    out = map_path.with_suffix(".nav.h5")
    legplan = str(Path(sys.executable).with_name("legplan"))
    commands = {"legplan --help": [legplan, "--help"],
                "legplan nav search (1 m, 256² map)": [
                    legplan, "nav", "search", str(map_path), "--start", *map(str, a), "--goal", *map(str, b),
                    "-o", str(out), "--overwrite", "-q"]}
    results = {}
    for label, command in commands.items():
        walls, cpus = [], []
        for _ in range(runs):
            before = resource.getrusage(resource.RUSAGE_CHILDREN)
            clock = time.perf_counter()
            subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
            walls.append(time.perf_counter() - clock)
            after = resource.getrusage(resource.RUSAGE_CHILDREN)
            cpus.append(after.ru_utime + after.ru_stime - before.ru_utime - before.ru_stime)
        results[label] = {"wall_s": statistics.median(walls), "cpu_s": statistics.median(cpus)}
    return results


def scale_table(results: dict) -> list[str]:
    lines = ["| map | planner | solved | median time (s) | max time (s) | time ratio | median CPU (s) | "
             "median expansions | peak memory (MB) | median T (s) | median effort J | median length ratio |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for map_name, entry in results.items():
        astar_time = entry["astar"]["median_planning_time_s"]
        reference = {i: row["length"] for i, row in enumerate(entry["astar"]["queries"])
                     if row["success"]}
        for label, summary in entry.items():
            rows = summary["queries"]
            ratios = [row["length"] / reference[i] for i, row in enumerate(rows)
                      if row["success"] and i in reference]
            solved = sum(row["success"] for row in rows)
            lines.append(
                f"| {map_name} | {label} | {solved}/{len(rows)} | "
                f"{summary['median_planning_time_s']:.2f} | {summary['max_planning_time_s']:.2f} | "
                f"{summary['median_planning_time_s'] / astar_time:.2f}× | {summary['median_cpu_time_s']:.2f} | "
                f"{summary['median_expansions']:.0f} | {summary['peak_memory_mb']:.0f} | "
                f"{summary['median_duration_s']:.1f} | {summary['median_effort']:.2f} | "
                f"{statistics.median(ratios) if ratios else float('nan'):.3f} |")
    return lines


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
                   str(args.repeats), "--seed", str(args.seed), "--result-only", str(out)] + \
            (["--max-expansions", str(args.max_expansions)] if args.max_expansions else [])
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
                        help="Expansion limit (default: NavParams' own, scaled with the map)")
    parser.add_argument("--scale", type=int, default=0, metavar="N",
                        help="also N queries per synthetic street map (nav_scale, module doc)")
    parser.add_argument("--scale-dir", type=Path,
                        help="where nav_scale writes its .map/.scen files")
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
    scale, startup = measure_scale(args) if args.scale else (None, None)
    params = NavParams.for_robot(load_robot("jueying_mini").navigation).replace(
        max_expansions=args.max_expansions)
    out = {"date": datetime.date.today().isoformat(), "machine": machine(),
           "load_average": {"start": load_start, "end": load_average()}, "seed": args.seed,
           "queries": args.queries, "repeats": args.repeats, "params": params.as_dict(),
           "variants": args.variant, "maps": results}
    if before is not None:
        out["before"] = {"revision": args.before, "maps": before}
    if scale is not None:
        out["scale"] = scale
        out["startup"] = startup
    write_result("nav_search", out)
    if args.no_append:
        return
    lines = [f"## nav search: kinodynamic A* vs grid A* ({out['date']}, {out['machine']}, "
             f"load avg {load_start:.1f} → {out['load_average']['end']:.1f})", "",
             f"{args.queries} seeded start/goal pairs per map (seed {args.seed}), median of "
             f"{args.repeats} runs per query, default NavParams (weight {params.weight}, "
             f"μ={params.mu}, τ={params.tau} s, pos_res {params.pos_res} m, vel_res "
             f"{params.vel_res} m/s, one-shot radius {params.oneshot_radius} m, expansion limit "
             f"{params.max_expansions or 'scaled: max(map cells, 200000)'}). "
             "Ratio: median planning time vs grid A*. "
             f"Where the two sides differ: kinodynamic A* runs weighted (weight {params.weight}: cost within "
             f"{params.weight:g}× the lattice optimum, up to 2.5× that when a stalled search restarts), grid A* "
             "unweighted with the admissible octile heuristic, i.e. optimal on its 8-connected grid; and they "
             "minimise different costs (ρ·time + effort + collision cost over motion primitives vs costmap-weighted length). "
             "µs/expansion: median over queries of time/expansions (kinoastar: in brackets the "
             f"steady-state search loop, one-shot off, weight 1, {STEADY_EXPANSIONS} expansions, "
             "median of the first 5 queries).", ""] + table(results)
    if before is not None:
        lines += [""] + before_after(before, results, args.before)
    if scale is not None:
        lines += ["", "### nav_scale: synthetic street maps (issue 19)", "",
                  f"{args.scale} seeded queries per map (seed {args.seed} + size), one run each, "
                  "same run as above; maps, `.scen` files and generator described in "
                  "bench/nav_search.py (synthetic stand-ins for MovingAI street maps). Length "
                  "ratio: path length / grid A*'s on the same query. 'kinoastar (old)': "
                  "geodesic_bound=0, max_expansions=200000 (the previous defaults).", ""] + \
            scale_table(scale) + ["", SCALE_NOTES, "", "Start-up (issue 19: shell pipelines call legplan once "
                                  "per stage and query), median of 5 fresh processes, CPU = the child's user + "
                                  "system time: " + "; ".join(f"`{label}` {v['wall_s']:.2f} s wall, {v['cpu_s']:.2f} s CPU"
                                                              for label, v in startup.items()) + "."]
    update_benchmarks("nav_search", "\n".join(lines))


if __name__ == "__main__":
    main()
