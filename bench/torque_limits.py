"""What keeping |Jᵀf| inside the joints' torque limits costs the planner, on bench/dyn.py's cases.

    .venv/bin/python bench/torque_limits.py [--cases KEY,KEY] [--repeats 1] [--costs none,paper] [--no-append]

The shipped anymal's robot.yaml names no `torque_limits`; its planner's model
(`legplan.dyn.tasks.centroidal_model`) now carries the URDF's 40 N m efforts
(`legplan.robots.torque_limits`) and keeps every stance force inside each leg's torque polytope
(the `joint_torque` constraint). Side by side on every bench/dyn.py case, from the same heuristic
guess: TOWR's scalar model (`robot.centroidal`: max_normal_force and friction alone, as bench/dyn.py
plans) and the planner's model with the limits. CPU seconds of the solve (every
`solve_augmented_lagrangian` call, bench/dyn.py's `SolveClock`), median of `--repeats` runs; LM
iterations; whether it solved; and the independent check (`check_trajectory`), which judges
`joint_torque` against the same limits for both models.

Writes bench/results/torque_limits.json and the `torque_limits` section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import statistics
import sys

import dyn as bench_dyn  # bench/dyn.py: its cases, its clock and its dense check
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result
from legplan.dyn.settings import PAPER, DynParams
from legplan.dyn.tasks import centroidal_model
from legplan.dyn.terrain import TerrainModel
from legplan.robots import load_robot
from legplan.terrain import build_map

PRESETS = {"none": DynParams(), "paper": PAPER}
TOWR = {case["key"]: case["towr"]["cpu"] for case in bench_dyn.CASES if case["towr"] and not case["towr"].get("failed")}


def measure(case, model, terrain, tmap, robot, params, repeats: int) -> dict:
    solves, result = [], None
    for _ in range(repeats):
        result, _, solve = bench_dyn.plan_once(case, model, terrain, params)
        solves.append(solve)
    check = bench_dyn.dense_check(result.samples, model, tmap, robot, result.problem.form.knots)
    return {"cpu_solve_s": statistics.median(solves), "runs_solve_s": solves, "iterations": result.solve.iterations,
            "success": bool(result.success), "reason": result.solve.reason,
            "check_ok": bool(check and check.get("ok")), "check_failed": (check or {}).get("failed"),
            "joint_torque": ((check or {}).get("worst") or {}).get("joint_torque")}


def markdown(result: dict) -> str:
    lines = [f"## torque_limits — the planner inside the URDF's joint efforts (`bench/torque_limits.py`, "
             f"{result['date']}, {result['machine']}, {result['code']}, load {result['load_start']:.1f} → "
             f"{result['load_end']:.1f})", "",
             "The shipped anymal (robot.yaml without `torque_limits`, URDF efforts 40 N m) on bench/dyn.py's cases: "
             "TOWR's scalar model (`robot.centroidal`, what bench/dyn.py plans with) against the planner's model "
             "(`centroidal_model`: |Jᵀf| ≤ 0.95 × 40 N m at every dynamics sample of a stance). Solve CPU s, median of "
             f"{result['repeats']} run(s) on a shared 2-core machine (noisy: see the load); `joint_torque` is the "
             "check's worst |τ|/τ_max (bound 1.001 for both).", "",
             "| case | costs | scalar: solve s / it | outcome | joint_torque | limits: solve s / it | outcome | joint_torque | limits ÷ scalar | TOWR s / limits ÷ TOWR |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for key, by_costs in result["cases"].items():
        for costs, pair in by_costs.items():
            a, b = pair["scalar"], pair["limits"]

            def cell(r):
                verdict = ("not solved" if not r["success"] else "check passed" if r["check_ok"]
                           else "check failed: " + ", ".join(r["check_failed"]))
                return (f"{r['cpu_solve_s']:.2f} / {r['iterations']}", verdict,
                        f"{r['joint_torque']:.2f}" if r["joint_torque"] is not None else "–")
            ca, cb = cell(a), cell(b)
            towr = TOWR.get(key)
            versus = "–" if towr is None else f"{towr:.2f} / {b['cpu_solve_s'] / towr:.2f}×"
            lines.append(f"| {key} | {costs} | {ca[0]} | {ca[1]} | {ca[2]} | {cb[0]} | {cb[1]} | {cb[2]} | "
                         f"{b['cpu_solve_s'] / a['cpu_solve_s']:.2f} | {versus} |")
    return "\n".join(lines)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--cases", default="", help="comma-separated bench/dyn.py case keys (default: all)")
    ap.add_argument("--costs", default="none", help="comma-separated presets: none, paper")
    ap.add_argument("--repeats", type=int, default=1)
    ap.add_argument("--no-append", action="store_true", help="do not write the JSON result nor BENCHMARKS.md")
    args = ap.parse_args()
    robot = load_robot("anymal")
    models = {"scalar": robot.centroidal, "limits": centroidal_model(robot)}
    result = {"date": datetime.datetime.utcnow().strftime("%Y-%m-%d %H:%M UTC"), "machine": machine(),
              "code": code_version(), "load_start": load_average(), "repeats": args.repeats, "cases": {}}
    maps = {}
    for case in bench_dyn.CASES:
        if args.cases and case["key"] not in args.cases.split(","):
            continue
        if case["map"] not in maps:
            tmap = build_map(ROOT / "maps" / f"{case['map']}.yaml")
            maps[case["map"]] = (tmap, TerrainModel(tmap))
        tmap, terrain = maps[case["map"]]
        for costs in args.costs.split(","):
            pair = {name: measure(case, model, terrain, tmap, robot, PRESETS[costs], args.repeats)
                    for name, model in models.items()}
            result["cases"].setdefault(case["key"], {})[costs] = pair
            print(f"{case['key']} {costs}: {pair}", file=sys.stderr, flush=True)
    result["load_end"] = load_average()
    if not args.no_append:
        write_result("torque_limits", result)
        update_benchmarks("torque_limits", markdown(result))
    print(markdown(result))


if __name__ == "__main__":
    main()
