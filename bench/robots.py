"""Benchmark of published quadrupeds from their URDF to an executed motion, with no hand edits.

    .venv/bin/python bench/robots.py [--robots anymal_b,go1] [--tasks "pallet trot"] [--work DIR] [--update] [--no-append]

For each robot of example-robot-data (a test dependency: ANYmal B and C, HyQ, Go1, Solo12) and the
shipped `anymal`, exactly what a user runs, through the `legplan` command:

1. `legplan robot init URDF -o WORK/NAME` (nothing but what it drafts) and `legplan robot check`;
2. four tasks scaled to the robot, whose body length L is the spread of its nominal feet along x and
   whose standing height h is its centroidal base height: a flat walk and a flat trot from (0, 0, 0)
   to (L, 0, 0), and a pallet walk and a pallet trot from (-1.4 L, 0, 0) onto a pallet of height h / 3
   whose near edge is at x = 0 (goal (0.9 L, 0, 0)), with the robot's own pallet map. A task's strides
   are its default or more (`strides_for`): enough that the body passes a standing foot by no more
   than the range-of-motion box's x extent 2 r_x per stance (a foot stands `STANCE_SHARE` of a
   stride), the duration grown with them (same phase durations);
3. `legplan dyn plan` (plan success, the independent dense check) and `legplan dyn simulate`
   (MuJoCo success, rms base position and orientation tracking error); the pallet trot with the
   legs' spheres kept `TROT_LEG_CLEARANCE` above the terrain (`--param leg_clearance`, the same on
   every robot): a trot's legs sweep past the pallet's edge within a few hundredths of a second,
   faster than the controller tracks them: at the default 2 cm Solo12's hind shanks struck it, at 3 cm
   its trunk reached the pallet under the simulator's edge lift.

Writes bench/results/robots.json and the `robots` section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

import numpy as np
import yaml

from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result

LEGPLAN = str(Path(sys.executable).with_name("legplan"))

# name -> URDF below example-robot-data's robots/ folder (None: the shipped robot of that name)
ROBOTS = {
    "anymal": None,
    "anymal_b": "anymal_b_simple_description/robots/anymal.urdf",
    "anymal_c": "anymal_c_simple_description/urdf/anymal.urdf",
    "hyq": "hyq_description/robots/hyq_no_sensors.urdf",
    "go1": "go1_description/urdf/go1.urdf",
    "solo12": "solo_description/robots/solo12.urdf",
}

# task -> (map kind, gait, strides, duration in s)
TASKS = {"flat walk": ("flat", "walk", 4, 4.0), "flat trot": ("flat", "trot", 4, 2.4),
         "pallet walk": ("pallet", "walk", 4, 5.5), "pallet trot": ("pallet", "trot", 6, 3.6)}
# gait -> the share of a stride a foot stands (TOWR's Walk2: swings of 0.13 + 0.25 + 0.13 s in 1.52 s;
# Run2: a diagonal pair of 0.4 s in 1.0 s)
STANCE_SHARE = {"walk": 1.0 - 0.51 / 1.52, "trot": 0.4}
KNOT_DT = 0.1  # s, the planner's base knot spacing (DynParams.dt)
TROT_LEG_CLEARANCE = 0.04  # m, the pallet trot's leg clearance (module docstring)


def strides_for(gait: str, strides: int, duration: float, distance: float, reach_x: float) -> tuple[int, float]:
    """(strides, duration) of a task over `distance` (m) for a robot whose range-of-motion box has
    the x half extent `reach_x`: the given ones, or more strides where a stride would carry the
    body farther past a standing foot than the box's extent 2·reach_x (an infeasible step), the
    duration scaled with the strides and rounded up to whole base intervals (`KNOT_DT`: the
    planner's between-knot dynamics samples then fall on the check's 10 ms grid)."""
    needed = int(np.ceil(STANCE_SHARE[gait] * distance / (2.0 * reach_x) - 1e-9))
    more = max(strides, needed)
    return more, round(float(np.ceil(duration * more / strides / KNOT_DT - 1e-9) * KNOT_DT), 9)


def robots_folder() -> Path:
    """example-robot-data's robots/ folder (installed as cmeel's data prefix)."""
    return Path(metadata.distribution("example-robot-data").locate_file(
        "cmeel.prefix/share/example-robot-data/robots"))


def run(args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run([LEGPLAN, *map(str, args)], capture_output=True, text=True)


def last_line(process: subprocess.CompletedProcess) -> str:
    lines = [line for line in (process.stderr + process.stdout).splitlines() if line.strip()]
    return lines[-1][:200] if lines else ""


def summary(path: Path) -> dict:
    from legplan.artefacts import open_artefact, read_summary

    with open_artefact(path) as handle:
        return {key: value for key, (value, _) in read_summary(handle).items()}


def robot_shape(folder: Path) -> tuple[float, float, float]:
    """(body length L, standing height h, range-of-motion x half extent) from a robot folder's
    centroidal section."""
    spec = yaml.safe_load((folder / "robot.yaml").read_text())
    feet = [spec["centroidal"]["nominal_feet"][leg] for leg in spec["centroidal"]["nominal_feet"]]
    xs, zs = [f[0] for f in feet], [f[2] for f in feet]
    return max(xs) - min(xs), -sum(zs) / len(zs), float(spec["centroidal"]["range_of_motion"][0])


def write_maps(work: Path, length: float, height: float) -> dict[str, Path]:
    flat = {"name": "flat", "resolution": 0.01, "extent": {"x": [-2 * length, 3 * length], "y": [-2 * length, 2 * length]},
            "ground": 0.0, "primitives": []}
    top = round(height / 3, 3)
    pallet = dict(flat, name="pallet", extent={"x": [-3 * length, 3 * length], "y": [-2 * length, 2 * length]},
                  primitives=[{"type": "box", "center": [1.1 * length, 0.0], "size": [2.2 * length, 2.0 * length],
                               "top": top},
                              {"type": "slope", "center": [0.015, 0.0], "size": [0.03, 2.0 * length],
                               "from": 0.0, "to": top}])
    maps = {}
    for spec in (flat, pallet):
        (work / f"{spec['name']}.yaml").write_text(yaml.safe_dump(spec))
        maps[spec["name"]] = work / f"{spec['name']}.h5"
        done = run(["map", "build", work / f"{spec['name']}.yaml", "-o", maps[spec["name"]], "--overwrite", "-q"])
        if done.returncode:
            raise RuntimeError(f"map build: {last_line(done)}")
    return maps


def bench_robot(name: str, urdf: Path | None, work: Path, tasks=tuple(TASKS)) -> dict:
    row = {"robot": name, "tasks": {}}
    folder = work / name
    if urdf is None:
        folder = Path(str(ROOT / "robots" / name))
    else:
        init = run(["robot", "init", urdf, "-o", folder, "--name", name, "--overwrite", "-q"])
        row["init"] = init.returncode == 0
        if init.returncode:
            row["init_error"] = last_line(init)
            return row
    check = run(["robot", "check", folder, "--json"])
    try:
        report = json.loads(check.stdout)
        if isinstance(report, dict):
            row["check_errors"] = len(report.get("errors", []))
        else:  # a list of findings, each with its severity
            row["check_errors"] = sum(1 for item in report
                                      if not isinstance(item, dict) or item.get("severity", "error") == "error")
    except json.JSONDecodeError:
        row["check_errors"] = None
    row["check_exit"] = check.returncode
    length, height, reach_x = robot_shape(folder)
    row["length"], row["height"] = length, height
    (work / f"{name}-maps").mkdir(parents=True, exist_ok=True)
    maps = write_maps(work / f"{name}-maps", length, height)
    for task in tasks:
        kind, gait, strides, duration = TASKS[task]
        start, goal = ((0, 0, 0), (length, 0, 0)) if kind == "flat" else ((-1.4 * length, 0, 0), (0.9 * length, 0, 0))
        strides, duration = strides_for(gait, strides, duration, goal[0] - start[0], reach_x)
        traj, sim = work / f"{name}-{task.replace(' ', '_')}.h5", work / f"{name}-{task.replace(' ', '_')}-sim.h5"
        cpu = time.process_time()
        extra = ["--param", f"leg_clearance={TROT_LEG_CLEARANCE}"] if task == "pallet trot" else []
        planned = run(["dyn", "plan", maps[kind], "--robot", folder, "--gait", gait, "--strides", strides,
                       "--duration", duration, "--start", *start, "--goal", *goal, "-o", traj, "--overwrite", "-q",
                       *extra])
        entry = {"plan_exit": planned.returncode, "strides": strides, "duration": duration}
        if planned.returncode in (0, 1) and traj.exists():
            plan_summary = summary(traj)
            entry.update(planned=bool(plan_summary.get("succeeded")),
                         check_passed=bool(plan_summary.get("check_passed", 0)),
                         solve_time=plan_summary.get("median_solve_time"))
        else:
            entry["error"] = last_line(planned)
        if traj.exists():
            simulated = run(["dyn", "simulate", traj, maps[kind], "-o", sim, "--overwrite", "-q"])
            entry["sim_exit"] = simulated.returncode
            if sim.exists():
                sim_summary = summary(sim)
                entry.update(executed=bool(sim_summary.get("succeeded")),
                             rms_position=sim_summary.get("median_rms_position_error"),
                             rms_orientation=sim_summary.get("median_rms_orientation_error"))
            else:
                entry["sim_error"] = last_line(simulated)
        if "planned" in entry and not entry["planned"]:
            entry["error"] = last_line(planned)
        entry["children_cpu"] = time.process_time() - cpu
        row["tasks"][task] = entry
        print(f"{name} {task}: {entry}", file=sys.stderr, flush=True)
    return row


def merged_rows(kept: dict, rows: list[dict]) -> list[dict]:
    """The rows of an earlier result with the tasks of `rows` replaced, robot by robot and task by task;
    every task entry keeps the run (commit, date, load) it came from."""
    fallback = {key: kept[key] for key in ("date", "commit", "load_start", "load_end")}
    merged = {}
    for row in kept["rows"]:
        run = row.get("run", fallback)
        merged[row["robot"]] = {**{k: v for k, v in row.items() if k != "run"},
                                "tasks": {task: {"run": run, **entry} for task, entry in row["tasks"].items()}}
    for row in rows:
        old = merged.get(row["robot"], {"tasks": {}})
        merged[row["robot"]] = {**old, **{k: v for k, v in row.items() if k != "tasks"},
                                "tasks": {**old["tasks"], **row["tasks"]}}
    return list(merged.values())


def markdown(result: dict) -> str:
    lines = [f"## robots — published quadrupeds from their URDF to MuJoCo ({result['date']}, {result['machine']}, "
             f"{result['commit']}, load {result['load_start']:.1f} → {result['load_end']:.1f})", "",
             "`bench/robots.py`: `robot init` (no hand edits) → `robot check` → `dyn plan` → `dyn simulate`; tasks "
             "scaled to the robot (body length L, standing height h): flat walk/trot to (L, 0), pallet of height "
             "h/3 from (-1.4 L, 0) to (0.9 L, 0); strides as given (walks 4, flat trot 4, pallet trot 6) or more "
             "where a stride would carry the body past a standing foot farther than the range-of-motion box "
             f"(durations scaled with them); the pallet trot with `--param leg_clearance={TROT_LEG_CLEARANCE}`. One run each (the "
             "outcomes are deterministic).", "",
             "| robot | init | check errors | task | strides / s | planned | check passed | executed | rms pos (m) | rms rot (rad) | note |",
             "|---|---|---|---|---|---|---|---|---|---|---|"]
    def run_of(entry):
        run = entry.get("run", result)
        return run["commit"], run["date"], run["load_start"], run["load_end"]

    entries = [(row["robot"], task, entry) for row in result["rows"] for task, entry in row.get("tasks", {}).items()]
    runs = sorted({run_of(entry) for _, _, entry in entries})
    if len(runs) > 1:
        lines.insert(2, "Rows from several runs: " + "; ".join(
            f"{', '.join(f'{robot} {task}' for robot, task, entry in entries if run_of(entry) == run)} at {run[0]} "
            f"({run[1]}, load {run[2]:.1f} → {run[3]:.1f})" for run in runs) + ".\n")
    for row in result["rows"]:
        if not row.get("init", True):
            lines.append(f"| {row['robot']} | failed | – | – | – | – | – | – | – | – | {row.get('init_error', '')} |")
            continue
        for task, entry in row["tasks"].items():
            def num(key):
                value = entry.get(key)
                return "–" if value is None else f"{value:.3f}"
            note = (entry.get("error") or entry.get("sim_error") or "").replace("|", "/")
            shape = f"{entry.get('strides', '–')} / {entry.get('duration', float('nan')):.2f}"
            lines.append(f"| {row['robot']} | ok | {row.get('check_errors')} | {task} | {shape} | {entry.get('planned', False)} | "
                         f"{entry.get('check_passed', False)} | {entry.get('executed', False)} | {num('rms_position')} | "
                         f"{num('rms_orientation')} | {note} |")
    for task in result.get("tasks", TASKS):
        done = [r["tasks"].get(task, {}).get("executed", False) for r in result["rows"]]
        lines.append(f"\n{task}: executed on {sum(done)}/{len(done)} robots.")
    return "\n".join(lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--robots", default=",".join(ROBOTS), help="comma-separated robot keys")
    parser.add_argument("--tasks", default=",".join(TASKS), help="comma-separated tasks")
    parser.add_argument("--work", help="keep the robot folders and artefacts in this folder (default: a temporary one)")
    parser.add_argument("--update", action="store_true", help=(
        "replace only these robots' rows of bench/results/robots.json (same tasks), keeping the others' with "
        "their own commit and load; the table says which rows came from which run"))
    parser.add_argument("--no-append", action="store_true", help="do not touch BENCHMARKS.md (nor the JSON result)")
    args = parser.parse_args()
    tasks = [task.strip() for task in args.tasks.split(",")]
    unknown = sorted(set(tasks) - set(TASKS))
    if unknown:
        parser.error(f"--tasks: unknown task '{unknown[0]}' (tasks: {', '.join(TASKS)})")
    folder = robots_folder()
    load_start = load_average()
    with tempfile.TemporaryDirectory(prefix="legplan-bench-robots-") as temporary:
        work = Path(args.work or temporary)
        work.mkdir(parents=True, exist_ok=True)
        rows = [bench_robot(name, None if ROBOTS[name] is None else folder / ROBOTS[name], work, tasks)
                for name in args.robots.split(",")]
    run_info = {"date": str(datetime.date.today()), "commit": code_version(), "load_start": load_start,
                "load_end": load_average()}
    for row in rows:
        for entry in row["tasks"].values():
            entry["run"] = run_info
    result = {**run_info, "machine": machine(), "tasks": tasks, "rows": rows}
    previous = ROOT / "bench" / "results" / "robots.json"
    if args.update and previous.exists():
        result["rows"] = merged_rows(json.loads(previous.read_text()), rows)
        result["tasks"] = list(TASKS)
    if not args.no_append:
        write_result("robots", result)
        update_benchmarks("robots", markdown(result))
    print(markdown(result))


if __name__ == "__main__":
    os.environ.setdefault("PYTHONUNBUFFERED", "1")
    main()
