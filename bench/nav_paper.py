"""Kinodynamic A* + TEB in closed-loop simulation vs the paper's Tables II and III, and TEB compute time.

Table II: on maps/nav_30m.yaml, `--pairs` seeded start/goal pairs (free cells with clearance
≥ 0.8 m, 10–18 m apart, `numpy.random.default_rng(seed)`), each run twice through
`legplan.nav.simulate` with the same TEB (10 Hz, 5 m window): global planner kinodynamic A* vs grid
("traditional") A* whose waypoints are timed at v_x max. Total running time and effort
J = ∫||a||² dt of the executed motion; collisions. Each pair is run on the fully known map and, as
in the paper's experiment (an incompletely known environment with unexpected obstacles), with two
hidden 0.6 m boxes — at the arc-length midpoints of the initial kinodynamic A* and grid A* plans,
the same boxes for both planners — that become known within the 4 m sensing radius and trigger
replanning from the robot's current state.
Table III: an empty 8 m × 8 m room; three parallel via points 1.5 m apart on the line x = 4 where
the robot must face the objects at x = 6.5 (heading 0) and stay 2 s. Both models use the same
yaw policy: the band's yaw is free between via points (initialized facing the direction of
travel) and the target heading is imposed only at each via point (the band's goal pose and the
arrival check); omnidirectional TEB vs the differential-drive variant. A third, omnidirectional
run initializes every band at the target heading instead (it then side-steps all the way: the
setup before the yaw was freed), to show what facing the direction of travel is worth. Time of each leg (arrival to arrival,
minus the dwell) and total.
Table II/III runs go `--jobs` at a time in parallel.
TEB compute, measured afterwards one process at a time (nothing else of this benchmark running):
time per simulation cycle (Table II pair 1, kinodynamic A*, first 15 s: 5 m window, warm-started or
re-initialized every cycle) and refining whole nav_30m kinodynamic A* trajectories (`refine_path`),
each in a fresh process, `--repeats` times, alternating with the same measurement of the reference:
the `legplan` package and `bench/` at commit `--reference` (maps and robots of the current tree;
none by default). Medians over the repeats. (Until the nav package was reorganised, the reference
was the TEB modules alone of c878aef over the current tree; they no longer fit the current tree.)
Everything runs with one BLAS thread (OPENBLAS/OMP/MKL_NUM_THREADS=1 unless set): with several
runs on the 2-core machine, BLAS worker threads oversubscribe the cores (TEB cycles measured ~1.7×
slower with the default threads, same results).
Writes bench/results/nav_paper.json and updates its section of BENCHMARKS.md.
    .venv/bin/python bench/nav_paper.py [--pairs 4] [--seed 0] [--jobs 2] [--repeats 3] [--reference REV] [--no-append]
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # before numpy/scipy load BLAS; inherited by the worker processes

import numpy as np

from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result

from legplan.nav import NavParams
from legplan.nav.collision import NavGrid
from legplan.nav.gridastar import plan_grid
from legplan.nav.kinoastar import plan_kinodynamic
from legplan.nav.simulate import Goal, NavRunParams, World, grid_planner, kinodynamic_planner, run_navigation
from legplan.nav.teb.distance import DistanceField
from legplan.nav.teb.params import TebParams
from legplan.nav.teb.reference import GlobalPath
from legplan.nav.teb.refine import refine_path
from legplan.robots import load_robot
from legplan.terrain import build_map
from legplan.terrain.grid import Grid2D
from legplan.terrain.layers import CostmapParams

PAPER_II = [(27.362, 31.794, 4.7630, 5.5047), (16.298, 25.395, 5.1730, 6.8421),
            (25.338, 31.000, 5.1201, 5.8651), (25.975, 25.594, 4.1946, 7.4720)]
PAPER_III = {"omni": [11, 10, 11, 32], "non-omni": [11, 20, 23, 54]}
TABLE3_RUNS = {"omni": (True, "velocity"), "non-omni": (False, "velocity"),
               "omni, yaw initialized at the target heading (side-steps)": (True, "heading")}
NAV = load_robot("jueying_mini").navigation
WALL_BUDGET = 240.0  # s of wall time per simulation run before it is recorded as failed
HIDDEN_BOX = 0.6  # m, side of each unexpected obstacle of the Table II runs with hidden obstacles
CYCLE_SIM_TIME = 15.0  # s simulated for the warm/cold cycle-time comparison
REFINE_QUERIES = [((0.5, 0.5), (29.5, 29.5)), ((0.5, 15.0), (29.5, 15.0)), ((6.0, 0.5), (24.0, 29.5))]
COMPUTE = """
import json, sys
sys.path[:0] = [{root!r}, {root!r} + "/bench"]
import nav_paper as bench
terrain = bench.build_map(bench.ROOT / "maps" / "nav_30m.yaml")
print(json.dumps({{"cycle": [bench.run_cycle(w) for w in (True, False)],
                  "refine": bench.refine_times(terrain, {queries!r})}}))
"""


def sample_pairs(terrain, count, rng):
    free = np.argwhere(terrain.distance >= 0.8)
    pairs = []
    while len(pairs) < count:
        a, b = free[rng.integers(len(free), size=2)]
        pa, pb = terrain.grid.xs[[a[1], b[1]]], terrain.grid.ys[[a[0], b[0]]]
        start, goal = np.array([pa[0], pb[0]]), np.array([pa[1], pb[1]])
        if 10.0 <= np.hypot(*(goal - start)) <= 18.0:
            pairs.append((start, goal, float(rng.uniform(-np.pi, np.pi))))
    return pairs


def hidden_boxes(terrain, start, goal) -> np.ndarray:
    """Cells of the unexpected obstacles of a pair: a HIDDEN_BOX square at the arc-length midpoint of
    the initial kinodynamic A* plan and one at that of the grid A* plan (the same for both runs)."""
    grid = NavGrid(terrain.costmap, terrain.distance, terrain.nav_params.l1, terrain.grid.origin,
                   terrain.grid.resolution)
    search = NavParams.for_robot(NAV)
    kino = plan_kinodynamic(grid, [*start, 0, 0], [*goal, 0, 0], search).trajectory.sample(0.05)[1]
    X, Y = terrain.grid.centres()
    mask = np.zeros(terrain.grid.shape, bool)
    for points in (kino, plan_grid(grid, [*start, 0, 0], [*goal, 0, 0], search).waypoints):
        s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(points, axis=0).T))])
        mid = [np.interp(s[-1] / 2, s, points[:, k]) for k in (0, 1)]
        mask |= (np.abs(X - mid[0]) <= HIDDEN_BOX / 2) & (np.abs(Y - mid[1]) <= HIDDEN_BOX / 2)
    return mask


def run_table2(job):
    planner_name, start, goal, yaw, hidden = job
    terrain = build_map(ROOT / "maps" / "nav_30m.yaml")
    unknown = hidden_boxes(terrain, start, goal) if hidden else np.zeros(terrain.grid.shape, bool)
    world = World(terrain.grid, terrain.occupancy, unknown, terrain.nav_params, NAV.circumscribed_radius)
    search = NavParams.for_robot(NAV)
    planner = kinodynamic_planner(search) if planner_name == "kinoastar" else grid_planner(search, NAV.limits.v_x_max)
    sim = NavRunParams(max_time=30.0 + 3.0 * float(np.hypot(*(goal - start))) / NAV.limits.v_x_max,
                    max_wall_seconds=WALL_BUDGET)
    r = run_navigation(world, planner, [*start, yaw], [Goal(tuple(goal))], NAV.limits, TebParams(), sim)
    return {"planner": planner_name, "hidden": hidden, "start": list(start), "goal": list(goal), **outcome(r)}


def outcome(r) -> dict:
    """Scalar results of a simulation run (cycle times kept for the compute-time rows)."""
    return {"success": r.success, "reason": r.reason, "running_time": r.running_time, "sim_time": float(r.times[-1]),
            "effort": r.effort(), "collisions": r.collisions, "replans": r.replans, "cycles": len(r.commands),
            "cold_starts": r.cold_starts, "median_iterations": float(np.median(r.band_iterations)),
            "cycle_seconds": r.compute_seconds.tolist()}


def run_table3(name):
    """One Table III run (`TABLE3_RUNS[name]`: model, yaw policy between via points)."""
    omni, yaw = TABLE3_RUNS[name]
    grid = Grid2D((0.025, 0.025), 0.05, (160, 160))
    X, Y = grid.centres()
    walls = (X < 0.2) | (X > 7.8) | (Y < 0.2) | (Y > 7.8)
    objects = (np.abs(X - 6.5) < 0.2) & ((np.abs(Y - 2.5) < 0.2) | (np.abs(Y - 4.0) < 0.2) | (np.abs(Y - 5.5) < 0.2))
    world = World(grid, walls | objects, np.zeros_like(walls), CostmapParams(),
                  NAV.circumscribed_radius)
    goals = [Goal((4.0, y), 0.0, 2.0) for y in (2.5, 4.0, 5.5)]
    sim = NavRunParams(max_time=150.0, yaw=yaw, heading=0.0, max_wall_seconds=WALL_BUDGET)
    r = run_navigation(world, kinodynamic_planner(NavParams.for_robot(NAV)), [1.0, 1.0, 0.0], goals, NAV.limits,
                 TebParams(omnidirectional=omni), sim)
    arrivals = r.goal_times
    legs = [arrivals[0]] + [arrivals[k] - arrivals[k - 1] - 2.0 for k in range(1, len(arrivals))]
    return {"name": name, "omni": omni, "legs": legs, "total": float(r.times[-1]), **outcome(r)}


def run_cycle(warm):
    """Table II pair 1 (kinodynamic A*) for `CYCLE_SIM_TIME` s, warm-started or re-initialized every cycle."""
    terrain = build_map(ROOT / "maps" / "nav_30m.yaml")
    start, goal, yaw = sample_pairs(terrain, 1, np.random.default_rng(0))[0]
    world = World(terrain.grid, terrain.occupancy, np.zeros(terrain.grid.shape, bool), terrain.nav_params,
                  NAV.circumscribed_radius)
    r = run_navigation(world, kinodynamic_planner(NavParams.for_robot(NAV)), [*start, yaw], [Goal(tuple(goal))],
                 NAV.limits, TebParams(), NavRunParams(max_time=CYCLE_SIM_TIME, warm_start=warm))
    return {"warm_start": warm, "cycles": len(r.commands), "median_ms": 1e3 * float(np.median(r.compute_seconds)),
            "p95_ms": 1e3 * float(np.percentile(r.compute_seconds, 95)),
            "median_iterations": float(np.median(r.band_iterations)), "median_poses": float(np.median(r.band_poses))}


def refine_times(terrain, queries):
    grid = NavGrid(terrain.costmap, terrain.distance, terrain.nav_params.l1, terrain.grid.origin,
                   terrain.grid.resolution)
    field = DistanceField.from_terrain(terrain)
    out = []
    for s, g in queries:
        res = plan_kinodynamic(grid, [*s, 0, 0], [*g, 0, 0], NavParams.for_robot(NAV))
        path = GlobalPath.from_trajectory(res.trajectory)
        runs = []
        for _ in range(3):
            t0 = time.perf_counter()
            ref = refine_path(path, NAV.limits, TebParams(), field)
            runs.append(time.perf_counter() - t0)
        out.append({"length": path.length, "poses": ref.band.n, "rounds": len(ref.result.rounds),
                    "seconds": float(np.median(runs)),
                    "max_violation": max(ref.violations.values()), "total_time": ref.band.duration})
    return out


def reference_tree(commit: str, where: Path) -> Path:
    """`legplan/` and `bench/` as at `commit`, with the current tree's maps and robots."""
    for name in ("maps", "robots"):
        shutil.copytree(ROOT / name, where / name, ignore=shutil.ignore_patterns("__pycache__"))
    archive = subprocess.run(["git", "-C", str(ROOT), "archive", commit, "legplan", "bench"], check=True,
                             capture_output=True)
    subprocess.run(["tar", "-x", "-C", str(where)], input=archive.stdout, check=True)
    shipped = where / "legplan" / "robot_models"
    if shipped.is_symlink():  # the package-data link to ../robots, pointing into `where`
        shipped.unlink()
        shipped.symlink_to(where / "robots")
    return where


def compute_times(root: Path) -> dict:
    """Cycle and refine times of the tree at `root`, measured in a fresh process."""
    code = COMPUTE.format(root=str(root), queries=REFINE_QUERIES)
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True)
    return json.loads(out.stdout.strip().splitlines()[-1])


def median_times(runs: list[dict]) -> dict:
    """Per-row medians over repeated `compute_times` runs."""
    cycle = [{k: (float(np.median([r["cycle"][i][k] for r in runs])) if k != "warm_start" else runs[0]["cycle"][i][k])
              for k in runs[0]["cycle"][i]} for i in range(len(runs[0]["cycle"]))]
    refine = [{k: float(np.median([r["refine"][i][k] for r in runs])) for k in runs[0]["refine"][i]}
              for i in range(len(runs[0]["refine"]))]
    return {"cycle": cycle, "refine": refine}


def _time(run) -> str:
    return f"{run['running_time']:.2f}" if run["success"] else f"failed ({run['reason']})"


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--pairs", type=int, default=4)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--repeats", type=int, default=3, help="fresh-process repeats of the compute-time rows")
    ap.add_argument("--reference", default="", help="commit of the reference legplan and bench ('' = none)")
    ap.add_argument("--no-append", action="store_true")
    args = ap.parse_args()
    terrain = build_map(ROOT / "maps" / "nav_30m.yaml")
    pairs = sample_pairs(terrain, args.pairs, np.random.default_rng(args.seed))
    jobs = [(p, s, g, y, hidden) for hidden in (False, True) for s, g, y in pairs for p in ("kinoastar", "astar")]
    loads = {"start": load_average()}
    with ProcessPoolExecutor(args.jobs) as pool:
        table2 = list(pool.map(run_table2, jobs))
        table3 = list(pool.map(run_table3, TABLE3_RUNS))
    loads["after_tables"] = load_average()
    with tempfile.TemporaryDirectory() as tmp:
        trees = {"ours": ROOT}
        if args.reference:
            trees[args.reference] = reference_tree(args.reference, Path(tmp))
        runs = {name: [] for name in trees}
        for _ in range(args.repeats):
            for name, root in trees.items():
                runs[name].append(compute_times(root))
    loads["end"] = load_average()
    compute = {name: median_times(r) for name, r in runs.items()}
    cycles = np.concatenate([r["cycle_seconds"] for r in table2 + table3])
    result = {"machine": machine(), "load_average": loads, "date": datetime.date.today().isoformat(),
              "code": code_version(), "jobs": args.jobs, "reference": args.reference, "repeats": args.repeats,
              "seed": args.seed,
              "pairs": [[list(s), list(g), y] for s, g, y in pairs], "table2": table2, "table3": table3,
              "compute": compute, "parallel_cycle_median_ms": 1e3 * float(np.median(cycles)),
              "parallel_cycle_p95_ms": 1e3 * float(np.percentile(cycles, 95))}
    slim = {**result, "table2": [{k: v for k, v in r.items() if k != "cycle_seconds"} for r in table2],
            "table3": [{k: v for k, v in r.items() if k != "cycle_seconds"} for r in table3]}
    write_result("nav_paper", slim)
    text = "\n".join(report(result, pairs)) + "\n"
    print(text)
    if not args.no_append:
        update_benchmarks("nav_paper", text)


PAIRS_NOTE = ("Where the two sides differ: our pairs are not the paper's. They are drawn with seed {seed} (free cells "
              "with clearance ≥ 0.8 m, 10–18 m apart) on maps/nav_30m.yaml, a map built like the paper's simulation "
              "map, not the map itself; the paper columns set its pair k beside our pair k. Compare magnitudes and "
              "which planner does better, not the rows number by number.")


def report(result: dict, pairs) -> list[str]:
    """The BENCHMARKS.md section: tables with the paper's numbers beside ours, and the verdict."""
    loads = result["load_average"]
    table2, table3, compute = result["table2"], result["table3"], result["compute"]
    lines = [f"## nav_paper — closed-loop kinodynamic A* + TEB vs paper Tables II/III ({result['date']}, "
             f"{result['machine']}, code {result['code']}; load average {loads['start']:.1f} at start, {loads['after_tables']:.1f} after "
             f"Tables II/III, {loads['end']:.1f} at end; shared machine)"]
    for hidden in (False, True):
        runs = [r for r in table2 if r["hidden"] == hidden]
        lines += ["", "| Table II, " + ("with 2 hidden 0.6 m boxes (paper's setting: unexpected obstacles, replanning)"
                                      if hidden else "fully known map") +
                  " | dist (m) | ours T kino / A* (s) | ours J kino / A* (m²/s³) | collisions | replans kino / A* | "
                  "paper T kino / A* (s) | paper J kino / A* |", "|---|---|---|---|---|---|---|---|"]
        for k in range(len(pairs)):
            kino, astar = runs[2 * k], runs[2 * k + 1]
            paper = PAPER_II[k] if k < len(PAPER_II) else (np.nan,) * 4
            lines.append(f"| pair {k + 1} | {np.hypot(*(pairs[k][1] - pairs[k][0])):.1f} | {_time(kino)} / {_time(astar)} | "
                         f"{kino['effort']:.3f} / {astar['effort']:.3f} | {kino['collisions']} / {astar['collisions']} | "
                         f"{kino['replans']} / {astar['replans']} | {paper[0]} / {paper[1]} | {paper[2]} / {paper[3]} |")
    lines += ["", PAIRS_NOTE.format(seed=result.get("seed", 0))]
    lines += ["", "| Table III (yaw free between via points, target heading at each) | leg 1 (s) | leg 2 (s) | "
              "leg 3 (s) | Σ legs (s) | run incl. 3×2 s dwell (s) | paper legs 1–3 / total (s) |",
              "|---|---|---|---|---|---|---|"]
    for r in table3:
        legs = " | ".join(f"{x:.1f}" for x in r["legs"]) + " | -" * (3 - len(r["legs"]))
        total = f"{r['total']:.1f}" if r["success"] else f"failed at {r['total']:.1f}: {r['reason']}"
        paper = PAPER_III.get(r["name"])
        paper = f"{paper[0]}, {paper[1]}, {paper[2]} / {paper[3]}" if paper else "-"
        lines.append(f"| {r['name']} | {legs} | {sum(r['legs']):.1f} | {total} | {paper} |")
    names = list(compute)
    lines += ["", f"TEB compute (one BLAS thread everywhere), one process at a time, median of {result['repeats']} fresh-process runs per tree, "
              "alternating" + (f"; reference = legplan and bench at {result['reference']} (maps, robots of the current tree)" if len(names) > 1 else "") + ":", "",
              "| TEB cycle, 5 m window (pair 1, kino A*, first 15 s) | tree | cycles | median (ms) | p95 (ms) | "
              "median LM iterations | median poses |", "|---|---|---|---|---|---|---|"]
    for i, label in enumerate(("warm start", "re-initialized every cycle")):
        for name in names:
            c = compute[name]["cycle"][i]
            lines.append(f"| {label} | {name} | {c['cycles']:.0f} | {c['median_ms']:.1f} | {c['p95_ms']:.1f} | "
                         f"{c['median_iterations']:.0f} | {c['median_poses']:.0f} |")
    lines += ["", "| whole-trajectory refine (`refine_path`) | tree | poses | rounds | time (ms) | max limit violation | "
              "band duration (s) |", "|---|---|---|---|---|---|---|"]
    for i in range(len(REFINE_QUERIES)):
        for name in names:
            r = compute[name]["refine"][i]
            lines.append(f"| {r['length']:.0f} m | {name} | {r['poses']:.0f} | {r['rounds']:.0f} | {1e3 * r['seconds']:.0f} | "
                         f"{r['max_violation']:.3f} | {r['total_time']:.1f} |")
    lines += ["", f"All Table II/III cycles (warm-started and re-initialized, runs {result['jobs']} at a time in parallel): median {result['parallel_cycle_median_ms']:.1f} ms, "
              f"p95 {result['parallel_cycle_p95_ms']:.1f} ms.", "", verdict(result)]
    return lines


def paper_line() -> str:
    """The paper's Table II in the same terms as ours."""
    rel = [(k - a) / a for k, a in (row[2:] for row in PAPER_II)]
    dt = [(k - a) / a for k, a in (row[:2] for row in PAPER_II)]
    return (f"lower effort in {sum(x < 0 for x in rel)} of {len(rel)} ({100 * min(rel):+.0f} % to {100 * max(rel):+.0f} %), "
            f"shorter running time in {sum(x < 0 for x in dt)} of {len(dt)} ({100 * min(dt):+.0f} % to {100 * max(dt):+.0f} %)")


def verdict(result: dict) -> str:
    """One line from the numbers: which of the paper's claims and our targets hold."""
    table2, table3, ours = result["table2"], result["table3"], result["compute"]["ours"]

    def table2_line(hidden):
        runs = [r for r in table2 if r["hidden"] == hidden]
        rel = [(k["effort"] - a["effort"]) / a["effort"] for k, a in zip(runs[::2], runs[1::2])]
        dt = [k["running_time"] - a["running_time"] for k, a in zip(runs[::2], runs[1::2])]
        return (f"{'with hidden boxes' if hidden else 'known map'}: lower executed effort in {sum(x < 0 for x in rel)} of "
                f"{len(rel)} pairs ({100 * min(rel):+.0f} % to {100 * max(rel):+.0f} %), shorter running time in "
                f"{sum(x < 0 for x in dt)} of {len(dt)} (kino − A* {min(dt):+.1f} to {max(dt):+.1f} s)")
    omni, diff = (sum(next(r for r in table3 if r["name"] == name)["legs"]) for name in ("omni", "non-omni"))
    warm = ours["cycle"][0]
    refine = max(r["seconds"] for r in ours["refine"])
    violation = max(r["max_violation"] for r in ours["refine"])
    ok = lambda good: "met" if good else "NOT met"
    return (f"Verdict (nav_paper): Table II — kinodynamic A* vs grid A*, {table2_line(False)}; {table2_line(True)} "
            f"(paper: {paper_line()}). Table III — omnidirectional "
            f"{omni:.1f} s vs non-omnidirectional {diff:.1f} s over the three legs: the paper's claim (omni faster) "
            f"{'holds' if omni < diff else 'does NOT hold'} ({100 * (omni - diff) / diff:+.0f} %; paper −41 %). "
            f"TEB cycle, 5 m window, warm start: median {warm['median_ms']:.1f} ms, p95 {warm['p95_ms']:.1f} ms "
            f"(target ≤ 20 ms median: {ok(warm['median_ms'] <= 20)}); whole-trajectory refine: at most "
            f"{1e3 * refine:.0f} ms (target ≤ 300 ms: {ok(refine <= 0.3)}), max limit violation {violation:.3f} "
            f"(≤ ε = 0.01: {ok(violation <= 0.01 + 1e-12)}).")


if __name__ == "__main__":
    main()
