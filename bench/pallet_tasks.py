"""Issue 34's execution targets on sampled single-pallet tasks, driven through the CLI as a user would.

    .venv/bin/python bench/pallet_tasks.py [--space tasks/single_pallet_walk.yaml] [--tasks 100] [--seed 0]
                                           [--jobs 2] [--costs none paper] [--work DIR]

1. --tasks tasks drawn from the task space with `numpy.random.default_rng(--seed)` by the library's own
   sampler (`legplan.learn.dataset.dataset_items`, what `legplan learn dataset` draws), written as a
   tasks CSV (start, goal, gait, strides, duration);
2. `legplan map build` of the space's map spec;
3. per costs setting: `legplan dyn plan MAP --tasks CSV --costs C --jobs J -o traj_C.h5`, then
   `legplan dyn simulate traj_C.h5 MAP --jobs J -o sim_C.h5` (which skips plans that did not succeed).

Counted per setting: planned (solved and the plan's independent check passed), check failed (solved,
check failed), not solved; executed (in MuJoCo: the goal reached without a fall) and fell, over the
planned tasks; and every task that passed its check and fell: its index, fall time, sim.h5's reason
and unplanned contacts (robot spheres other than the feet on the terrain), and the first 400 Hz-recorded
sample where the simulated foot contacts differ from the plan's (a foot the plan has in swing
carrying > `CONTACT_FORCE` N, or the reverse) — where the execution left the plan. Targets (issue 34):
planned-then-fell = 0, executed / planned ≥ 95 %.

CPU time of each command is its children's user + system time (`resource.getrusage`, the worker
processes included); wall time by `time.perf_counter`. Writes bench/results/pallet_tasks.json and the
pallet_tasks section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import csv
import datetime
import json
import os
import re
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
from common import ROOT, become_subreaper, code_version, load_average, machine, reap_orphans, update_benchmarks, write_result

CONTACT_FORCE = 1.0  # N: a simulated foot force above this counts as a contact
MISMATCH_SECONDS = 0.1  # a foot's contact differing from the plan's this long: the execution left the plan
TRACKING_BOUND = 0.05  # m: base position error that marks where the execution diverged
TARGET_EXECUTED = 0.95


def legplan_command() -> str:
    """The `legplan` entry point of the interpreter running this script (its venv)."""
    return os.fspath(Path(sys.executable).parent / "legplan")


def run_timed(args: list[str], log: Path) -> dict:
    """Run one CLI command (stderr to `log`); its exit code, wall and CPU (children's user + sys)
    seconds, the `--jobs` workers included: the caller is a child subreaper (`become_subreaper`),
    so the fork server and its workers, which the command does not reap, come back here."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    with open(log, "w") as err:
        code = subprocess.run(args, stdout=err, stderr=subprocess.STDOUT).returncode
    wall = time.perf_counter() - t0
    reap_orphans()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
    print(f"{' '.join(Path(a).name if i == 0 else a for i, a in enumerate(args))}: exit {code}, "
          f"{wall:.0f} s wall, {cpu:.0f} s CPU", file=sys.stderr, flush=True)
    if code not in (0, 1):  # 1: some task failed (recorded); anything else: the command itself failed
        sys.exit(f"{args[1:3]} failed with exit {code}; see {log}")
    return {"command": " ".join(Path(a).name if i == 0 else a for i, a in enumerate(args)), "exit": code,
            "wall_seconds": wall, "cpu_seconds": cpu}


def write_tasks_csv(space_path: str, n: int, seed: int, path: Path, first: int = 0) -> list[list[float]]:
    """Tasks `first` … `n` - 1 of the space's first `n` of `seed`, as the CSV `dyn plan --tasks` reads;
    returns the rows."""
    from legplan.learn.dataset import dataset_items
    from legplan.learn.space import read_space

    items = dataset_items(read_space(space_path), n, seed)
    rows = []
    with open(path, "w", newline="") as f:
        writer = csv.writer(f)
        writer.writerow(["start_x", "start_y", "start_yaw", "goal_x", "goal_y", "goal_yaw", "gait", "strides",
                         "duration"])
        for _, task, _ in items[first:]:
            row = [*map(float, task.start), *map(float, task.goal)]
            writer.writerow([repr(v) for v in row] + [task.gait, task.strides, repr(float(task.duration))])
            rows.append(row)
    return rows


def first_contact_mismatch(planned_t, planned_contact, sim_t, foot_forces, legs: list[str]) -> str:
    """The start of the first run of at least `MISMATCH_SECONDS` in which a simulated foot's contact
    (|f| > `CONTACT_FORCE`) differs from the plan's contact flag at that time, as
    't s: LEG planned swing, loaded' (or '' when none). Shorter runs occur in every successful execution:
    touch-down and lift-off lag the plan's switching times by a few 10 ms samples."""
    loaded = np.linalg.norm(foot_forces, axis=-1) > CONTACT_FORCE
    idx = np.clip(np.searchsorted(planned_t, sim_t, side="right") - 1, 0, len(planned_t) - 1)
    differs = (planned_contact[idx].astype(bool) != loaded) & (sim_t <= planned_t[-1])[:, None]
    step = float(np.median(np.diff(sim_t))) if len(sim_t) > 1 else 1.0
    need = max(1, int(round(MISMATCH_SECONDS / step)))
    run = np.zeros(len(legs), int)
    for k in range(len(sim_t)):
        run = np.where(differs[k], run + 1, 0)
        if (run >= need).any():
            leg = int(np.argmax(run >= need))
            start = k - need + 1
            state = "planned swing, loaded" if loaded[k, leg] else "planned stance, unloaded"
            return f"{sim_t[start]:.2f} s: {legs[leg]} {state}"
    return ""


def first_exceeding(t, values, bound: float) -> float:
    """The first time `values` exceed `bound` (NaN when never)."""
    over = np.flatnonzero(np.asarray(values) > bound)
    return float(t[over[0]]) if over.size else float("nan")


def count(traj: Path, sim: Path, first: int | None = None, offset: int = 0) -> dict:
    """Per costs setting: the counts of the module docstring and the planned-then-fell list (over the
    tasks with index < `first`, when given); task numbers reported + `offset` (the CSV's first task)."""
    import h5py

    with h5py.File(traj, "r") as ft, h5py.File(sim, "r") as fs:
        legs = str(fs.attrs["legs"]).split(",")
        plans = {int(g.attrs["index"]): g for g in ft["tasks"].values()
                 if first is None or int(g.attrs["index"]) < first}
        runs = {int(g.attrs["index"]): g for g in fs["tasks"].values() if first is None or int(g.attrs["index"]) < first}
        n = len(plans)
        solved = [i for i, g in plans.items() if bool(g.attrs.get("solved", g.attrs["success"]))]
        planned = [i for i, g in plans.items() if bool(g.attrs["success"])]
        check_failed = [i for i in solved if i not in planned]
        failed_metrics: dict[str, int] = {}
        for i in check_failed:
            check = plans[i]["check"]
            for name, node in check.items():
                if isinstance(node, h5py.Dataset) and not bool(node.attrs.get("passed", True)):
                    failed_metrics[name] = failed_metrics.get(name, 0) + 1
        executed = [i for i in planned if bool(runs[i].attrs["success"])]
        fell = [i for i in planned if bool(runs[i].attrs["fell"])]
        missed = [i for i in planned if i not in executed and i not in fell]
        fallen = []
        for i in fell:
            g, p = runs[i], plans[i]
            mismatch = first_contact_mismatch(p["samples/t"][()], p["samples/contact"][()], g["series/t"][()],
                                              g["series/foot_forces"][()], legs)
            fallen.append({"task": i + offset, "fall_time": float(g.attrs["fall_time"]), "reason": str(g.attrs["reason"]),
                           "unplanned_contacts": str(g.attrs["unplanned_contacts"]),
                           "unplanned_contact_time": float(g.attrs["unplanned_contact_time"]),
                           "qp_failures": int(g.attrs["qp_failures"]),
                           "first_contact_mismatch": mismatch,
                           "tracking_error_over_5cm": first_exceeding(g["series/t"][()], g["series/position_error"][()],
                                                                      TRACKING_BOUND)})
        skipped_executed = [i for i, g in runs.items() if i not in planned and not bool(g.attrs["skipped"])]
        return {"tasks": n, "solved": len(solved), "planned": len(planned), "check_failed": len(check_failed),
                "check_failed_tasks": sorted(i + offset for i in check_failed), "check_failed_metrics": failed_metrics,
                "not_solved": n - len(solved), "executed": len(executed), "fell": len(fell),
                "missed_goal": len(missed), "missed_goal_tasks": sorted(i + offset for i in missed),
                "executed_fraction": len(executed) / len(planned) if planned else float("nan"),
                "unplanned_executed": sorted(skipped_executed),
                "median_solve_seconds": float(np.median([float(g.attrs["solve_seconds"]) for i, g in plans.items()
                                                         if i in solved])) if solved else float("nan"),
                "planned_then_fell": fallen}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--space", default="tasks/single_pallet_walk.yaml")
    parser.add_argument("--tasks", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=2)
    parser.add_argument("--costs", nargs="+", default=["none", "paper"],
                        help="settings to run; the JSON's other settings (earlier runs) are kept")
    parser.add_argument("--first", type=int, default=0, help="run tasks --first … --tasks - 1 only (a separate "
                        "row: the rest of an earlier run's tasks)")
    parser.add_argument("--work", default="outputs/pallet_tasks", help="folder of the CSV and artefacts")
    parser.add_argument("--recount", action="store_true",
                        help="only recount the artefacts of --work into the JSON (its timings and loads kept)")
    parser.add_argument("--adopt", metavar="LOG", help="add the settings of an interrupted run of this script in "
                        "--work: its artefacts, and its commands' times from its stderr LOG")
    parser.add_argument("--load-start", type=float, help="with --adopt: the load average when that run started")
    parser.add_argument("--load-end", type=float, help="with --adopt: the load average when its last command ended")
    parser.add_argument("--started", help="with --adopt: when that run started (YYYY-MM-DD HH:MM UTC)")
    args = parser.parse_args()
    become_subreaper()
    work = (ROOT / args.work).resolve()
    if args.recount:
        return recount(work, args.costs)
    if args.adopt:
        return adopt(work, args)
    from legplan.learn.space import read_space

    space = read_space(ROOT / args.space)
    work.mkdir(parents=True, exist_ok=True)
    legplan = legplan_command()
    tasks_csv = work / "tasks.csv"
    write_tasks_csv(os.fspath(ROOT / args.space), args.tasks, args.seed, tasks_csv, args.first)
    map_h5 = work / "map.h5"
    build = run_timed([legplan, "map", "build", space.map, "-o", os.fspath(map_h5), "--overwrite", "-q"],
                      work / "map.log")
    result = previous_result(args.space, args.seed, args.jobs)
    for costs in args.costs:
        started, date = load_average(), datetime.datetime.now(datetime.timezone.utc)
        traj, sim = work / f"traj_{costs}.h5", work / f"sim_{costs}.h5"
        plan = run_timed([legplan, "dyn", "plan", os.fspath(map_h5), "--tasks", os.fspath(tasks_csv), "--costs", costs,
                          "--jobs", str(args.jobs), "-o", os.fspath(traj), "--overwrite", "-q"],
                         work / f"plan_{costs}.log")
        simulate = run_timed([legplan, "dyn", "simulate", os.fspath(traj), os.fspath(map_h5), "--jobs", str(args.jobs),
                              "-o", os.fspath(sim), "--overwrite", "-q"], work / f"simulate_{costs}.log")
        setting = {"date": date.strftime("%Y-%m-%d %H:%M UTC"), "code": code_version(), "load_average_start": started,
                   "load_average_end": load_average(), "work": os.fspath(work), "first_task": args.first,
                   **count(traj, sim, offset=args.first),
                   "map_build": build, "plan": plan, "simulate": simulate}
        result["settings"][costs if args.first == 0 else f"{costs}, tasks {args.first}–{args.tasks - 1}"] = setting
        write_result("pallet_tasks", result)
        print(f"costs {costs}: {setting['planned']}/{args.tasks} planned, {setting['executed']} executed, "
              f"{setting['fell']} fell", file=sys.stderr, flush=True)
    add_common_subset(result)
    write_result("pallet_tasks", result)
    update_benchmarks("pallet_tasks", "\n".join(section(result)))
    print("\n".join(section(result)))


def add_common_subset(result: dict) -> None:
    """When the settings ran different numbers of tasks: each larger one counted again on the first n
    tasks of the smallest (the same tasks), as `on_common_tasks`."""
    settings = {c: s for c, s in result["settings"].items() if not s.get("first_task", 0)}
    n = min(s["tasks"] for s in settings.values())
    for s in settings.values():
        s.pop("on_common_tasks", None)
        if s["tasks"] > n:
            work = Path(s["work"])
            costs = next(c for c, v in settings.items() if v is s)
            s["on_common_tasks"] = count(work / f"traj_{costs}.h5", work / f"sim_{costs}.h5", first=n)


def previous_result(space: str, seed: int, jobs: int) -> dict:
    """The JSON of earlier runs of the same space, seed and jobs (their settings are kept), or a new one."""
    path = ROOT / "bench" / "results" / "pallet_tasks.json"
    fresh = {"machine": machine(), "space": space, "seed": seed, "jobs": jobs, "settings": {}}
    if path.exists():
        old = json.loads(path.read_text())
        if all(old.get(key) == fresh[key] for key in ("machine", "space", "seed", "jobs")):
            return old
    return fresh


def adopt(work: Path, args) -> None:
    """Add --costs settings of an interrupted run (its JSON never written) from its artefacts and the
    `run_timed` lines of its stderr log."""
    timed = {}
    for line in Path(args.adopt).read_text().splitlines():
        match = re.fullmatch(r"(legplan .*): exit (\d+), (\d+) s wall, (\d+) s CPU", line)
        if match:
            timed[match[1]] = {"command": match[1], "exit": int(match[2]), "wall_seconds": float(match[3]),
                               "cpu_seconds": float(match[4])}
    result = previous_result(args.space, args.seed, args.jobs)
    for costs in args.costs:
        traj, sim = work / f"traj_{costs}.h5", work / f"sim_{costs}.h5"

        def find(*words):
            return next(v for k, v in timed.items() if all(w in k.split() for w in words))

        result["settings"][costs] = {
            "date": args.started, "code": code_version(), "load_average_start": args.load_start,
            "load_average_end": args.load_end, "work": os.fspath(work), "adopted_from_log": args.adopt,
            **count(traj, sim), "map_build": find("map", "build"), "plan": find("plan", costs),
            "simulate": find("simulate", os.fspath(traj))}
    add_common_subset(result)
    write_result("pallet_tasks", result)
    update_benchmarks("pallet_tasks", "\n".join(section(result)))
    print("\n".join(section(result)))


def recount(work: Path, settings: list[str]) -> None:
    """Recount `settings` of bench/results/pallet_tasks.json from the artefacts in `work`."""
    path = ROOT / "bench" / "results" / "pallet_tasks.json"
    result = json.loads(path.read_text())
    for costs in settings:
        result["settings"][costs].update(count(work / f"traj_{costs}.h5", work / f"sim_{costs}.h5"))
    add_common_subset(result)
    write_result("pallet_tasks", result)
    update_benchmarks("pallet_tasks", "\n".join(section(result)))
    print("\n".join(section(result)))


def section(result: dict) -> list[str]:
    """The BENCHMARKS.md section of a result."""
    settings = result["settings"]
    lines = ["## pallet tasks — issue 34's execution targets through the CLI (`bench/pallet_tasks.py`)", "",
             f"{result['machine']}; shared machine (2 cores, other agents' jobs running): times are noisy. Tasks of "
             f"`{result['space']}` (seed {result['seed']}, the library's sampler `legplan.learn.dataset.dataset_items`; "
             "a run of n tasks takes the first n), planned by `legplan dyn plan MAP --tasks CSV --costs C "
             f"--jobs {result['jobs']}` and executed by `legplan dyn simulate --jobs {result['jobs']}` (plans that did "
             "not succeed are skipped). Planned = solved and its check passed; executed = goal reached (10 cm, 0.2 rad) "
             "without a fall. Targets: planned-then-fell 0, executed ≥ 95 % of planned. CPU = user + system of the "
             "command and its workers.", "",
             "| costs | date | code | load start → end | tasks | planned | check failed | not solved | executed | fell "
             "| missed goal | executed / planned | median solve (s) | plan wall / CPU (s) | simulate wall / CPU (s) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for costs, s in settings.items():
        lines.append(f"| {costs} | {s['date']} | {s['code']} | {s['load_average_start']:.1f} → {s['load_average_end']:.1f} "
                     f"| {s['tasks']} | {s['planned']} | {s['check_failed']} | {s['not_solved']} | "
                     f"{s['executed']} | {s['fell']} | {s['missed_goal']} | {s['executed_fraction']:.0%} | "
                     f"{s['median_solve_seconds']:.2f} | {s['plan']['wall_seconds']:.0f} / {s['plan']['cpu_seconds']:.0f} | "
                     f"{s['simulate']['wall_seconds']:.0f} / {s['simulate']['cpu_seconds']:.0f} |")
        if "on_common_tasks" in s:
            c = s["on_common_tasks"]
            lines.append(f"| {costs}, its first {c['tasks']} tasks | | | | {c['tasks']} | {c['planned']} | "
                         f"{c['check_failed']} | {c['not_solved']} | {c['executed']} | {c['fell']} | {c['missed_goal']} | "
                         f"{c['executed_fraction']:.0%} | {c['median_solve_seconds']:.2f} | | |")
    lines += ["", "Plans that passed their check and fell (task: fall time; sim.h5's reason; unplanned contacts; "
              f"the first time a foot's simulated contact differed from the plan's for ≥ {MISMATCH_SECONDS} s; the "
              f"first time the base was more than {TRACKING_BOUND * 100:.0f} cm off the plan):", ""]
    for costs, s in settings.items():
        fallen = s["planned_then_fell"]
        lines.append(f"- {costs}: {len(fallen) or 'none'}")
        if s.get("adopted_from_log"):
            lines.append("  - (this setting's run was stopped after it, before its other setting: counts from its "
                         "artefacts, times from its log, loads read by `uptime` at its start and end)")
        lines += [f"  - task {f['task']}: {f['fall_time']:.2f} s; {f['reason']}; "
                  f"{f['unplanned_contacts'] or 'no unplanned contact'}; "
                  f"{f['first_contact_mismatch'] or 'contacts as planned'}; base error > 5 cm from "
                  f"{f['tracking_error_over_5cm']:.2f} s" for f in fallen]
        if s["check_failed_metrics"]:
            lines.append("  - check failures by metric: "
                         + ", ".join(f"{k} {v}" for k, v in sorted(s["check_failed_metrics"].items())))
        if s["missed_goal_tasks"]:
            lines.append(f"  - planned, no fall, goal missed: tasks {', '.join(map(str, s['missed_goal_tasks']))}")
    return lines


if __name__ == "__main__":
    main()
