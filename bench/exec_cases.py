"""Issue 34's execution target on bench/dyn.py's cases: plans that pass their check and fall in MuJoCo.

    .venv/bin/python bench/exec_cases.py [--cases flat_trot,...] [--costs none paper] [--jobs 2] [--work DIR]

bench/dyn.py's cases (TOWR's five, the 2-stride flat trot TOWR fails, the stairs walk), with and without
the paper's costs, driven through the CLI as a user would, one map at a time:

1. `legplan map build maps/MAP.yaml`;
2. per costs setting: `legplan dyn plan MAP --tasks CSV --costs C --jobs J` of the map's cases (the
   planner's model with the robot's torque limits, the independent check on), then `legplan dyn
   simulate` (which skips plans that did not succeed).

Per case and setting: planned (solved and its check passed), the check's failed metrics, executed (the
goal reached, 10 cm / 0.2 rad, without a fall), fall time, rms base tracking errors and the fraction
of ticks with a joint at its torque limit. Target (issue 34): no plan passes its check and falls.
Counting and the per-fall diagnosis are `bench/pallet_tasks.py`'s. Writes bench/results/exec_cases.json
and the exec_cases section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import os
import sys
from pathlib import Path

import h5py
from common import ROOT, become_subreaper, code_version, load_average, machine, update_benchmarks, write_result
from dyn import CASES
from pallet_tasks import count, legplan_command, run_timed


def write_cases_csv(cases: list[dict], path: Path) -> None:
    """The cases as the tasks CSV `dyn plan --tasks` reads."""
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["start_x", "start_y", "start_yaw", "goal_x", "goal_y", "goal_yaw", "gait", "strides",
                         "duration"])
        for case in cases:
            writer.writerow([repr(float(v)) for v in (*case["start"], *case["goal"])]
                            + [case["gait"], case["strides"], repr(float(case["duration"]))])


def per_case(cases: list[dict], traj: Path, sim: Path) -> list[dict]:
    """One row per case: planned, the check's failed metrics, the run's outcome and tracking."""
    rows = []
    with h5py.File(traj, "r") as ft, h5py.File(sim, "r") as fs:
        plans = {int(g.attrs["index"]): g for g in ft["tasks"].values()}
        runs = {int(g.attrs["index"]): g for g in fs["tasks"].values()}
        for i, case in enumerate(cases):
            p, r = plans[i], runs.get(i)
            failed = sorted(name for name, node in p["check"].items()
                            if isinstance(node, h5py.Dataset) and not bool(node.attrs.get("passed", True)))
            ran = r is not None and not bool(r.attrs["skipped"])
            rows.append({"case": case["key"], "label": case["label"], "solved": bool(p.attrs.get("solved", False)),
                         "planned": bool(p.attrs["success"]), "reason": str(p.attrs["reason"]),
                         "check_failed": failed, "iterations": int(p.attrs["iterations"]),
                         "solve_seconds": float(p.attrs["solve_seconds"]), "executed": ran and bool(r.attrs["success"]),
                         "fell": ran and bool(r.attrs["fell"]),
                         "fall_time": float(r.attrs["fall_time"]) if ran else float("nan"),
                         "sim_reason": str(r.attrs["reason"]) if r is not None else "",
                         "rms_position_error": float(r.attrs["rms_position_error"]) if ran else float("nan"),
                         "rms_orientation_error": float(r.attrs["rms_orientation_error"]) if ran else float("nan"),
                         "saturation": float(r.attrs["saturation"]) if ran else float("nan")})
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", help="comma-separated bench/dyn.py case keys (default: all)")
    parser.add_argument("--costs", nargs="+", default=["none", "paper"])
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--work", default="outputs/exec_cases", help="folder of the CSVs and artefacts")
    parser.add_argument("--from-json", action="store_true", help="rewrite the section from bench/results/exec_cases.json")
    args = parser.parse_args()
    if args.from_json:
        result = json.loads((ROOT / "bench" / "results" / "exec_cases.json").read_text())
        update_benchmarks("exec_cases", "\n".join(section(result)))
        return
    become_subreaper()  # the --jobs workers' CPU counts (`pallet_tasks.run_timed`)
    wanted = [c for c in CASES if not args.cases or c["key"] in args.cases.split(",")]
    work = (ROOT / args.work).resolve()
    work.mkdir(parents=True, exist_ok=True)
    legplan = legplan_command()
    started, date = load_average(), datetime.datetime.now(datetime.timezone.utc)
    result = {"machine": machine(), "code": code_version(), "date": date.strftime("%Y-%m-%d %H:%M UTC"),
              "load_average_start": started, "jobs": args.jobs, "rows": [], "commands": []}
    for map_name in dict.fromkeys(c["map"] for c in wanted):
        cases = [c for c in wanted if c["map"] == map_name]
        tasks_csv, map_h5 = work / f"{map_name}.csv", work / f"{map_name}.h5"
        write_cases_csv(cases, tasks_csv)
        result["commands"].append(run_timed([legplan, "map", "build", os.fspath(ROOT / "maps" / f"{map_name}.yaml"),
                                             "-o", os.fspath(map_h5), "--overwrite", "-q"], work / f"{map_name}_map.log"))
        for costs in args.costs:
            traj, sim = work / f"traj_{map_name}_{costs}.h5", work / f"sim_{map_name}_{costs}.h5"
            result["commands"].append(run_timed(
                [legplan, "dyn", "plan", os.fspath(map_h5), "--tasks", os.fspath(tasks_csv), "--costs", costs,
                 "--jobs", str(args.jobs), "-o", os.fspath(traj), "--overwrite", "-q"], work / f"plan_{map_name}_{costs}.log"))
            result["commands"].append(run_timed(
                [legplan, "dyn", "simulate", os.fspath(traj), os.fspath(map_h5), "--jobs", str(args.jobs),
                 "-o", os.fspath(sim), "--overwrite", "-q"], work / f"simulate_{map_name}_{costs}.log"))
            fallen = {f["task"]: f for f in count(traj, sim)["planned_then_fell"]}
            for i, row in enumerate(per_case(cases, traj, sim)):
                result["rows"].append({"costs": costs, **row, "diagnosis": fallen.get(i)})
            write_result("exec_cases", result)
    result["load_average_end"] = load_average()
    write_result("exec_cases", result)
    update_benchmarks("exec_cases", "\n".join(section(result)))
    print("\n".join(section(result)))


def section(result: dict) -> list[str]:
    """The BENCHMARKS.md section of a result."""
    rows = result["rows"]
    fell_after_check = [r for r in rows if r["planned"] and r["fell"]]
    cpu = sum(c["cpu_seconds"] for c in result["commands"])
    lines = [f"## exec_cases — bench/dyn.py's cases planned and executed through the CLI (`bench/exec_cases.py`, "
             f"{result['date']}, {result['machine']}, code {result['code']}, load {result['load_average_start']:.1f} → "
             f"{result['load_average_end']:.1f})", "",
             f"`legplan dyn plan MAP --tasks CSV --costs C --jobs {result['jobs']}` (the planner's model, the "
             f"independent check on) then `legplan dyn simulate --jobs {result['jobs']}` (ANYmal at its URDF's "
             "torque and velocity limits; plans that did not succeed are skipped). Planned = solved and its check "
             "passed; executed = the goal reached (10 cm, 0.2 rad) without a fall; τ saturated = ticks with a joint "
             f"at its torque limit. All commands: {cpu / 60:.0f} CPU min.", "",
             "| case | costs | planned | iterations | solve wall (s) | check failed | executed | rms pos (m) | rms rot (rad) "
             "| τ saturated |", "|---|---|---|---|---|---|---|---|---|---|"]
    for r in rows:
        planned = "yes" if r["planned"] else ("failed: check" if r["solved"] else "not solved")
        if not r["planned"]:
            outcome = "skipped"
        elif r["executed"]:
            outcome = "yes"
        elif r["fell"]:
            outcome = f"fell at {r['fall_time']:.2f} s"
        else:
            outcome = r["sim_reason"] or "—"
        tracking = (f"{r['rms_position_error']:.3f} | {r['rms_orientation_error']:.3f} | {100 * r['saturation']:.0f} %"
                    if r["planned"] else "— | — | —")
        lines.append(f"| {r['label']} | {r['costs']} | {planned} | {r['iterations']} | {r['solve_seconds']:.1f} | "
                     f"{', '.join(r['check_failed']) or '—'} | {outcome} | {tracking} |")
    lines += ["", f"Plans that passed their check and fell: {len(fell_after_check)} of "
              f"{sum(r['planned'] for r in rows)} planned (target 0)."]
    for r in fell_after_check:
        d = r["diagnosis"] or {}
        lines.append(f"- {r['label']}, {r['costs']}: fell at {r['fall_time']:.2f} s; {d.get('reason', '')}; "
                     f"{d.get('unplanned_contacts') or 'no unplanned contact'}; "
                     f"{d.get('first_contact_mismatch') or 'contacts as planned'}")
    return lines


if __name__ == "__main__":
    main()
