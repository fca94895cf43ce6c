"""Lateral push survived open loop vs closed loop (`dyn simulate --replan`, issue 39 item 3): the
largest +y push on the trunk a plan survives executed as planned (open loop) and replanned every
`--period` s from the simulated state (closed loop, `legplan.sim.replanning.Replanner`), bracketed
the same way for both as `bench/sim.py --push-only` brackets the open loop: a push of `PUSH_DURATION`
at half the plan, its impulse doubled from `PUSH_START` N s until a run fails, then halved down to
the case's resolution. Survived = reached the goal without falling. One run per impulse: MuJoCo,
the controller and the replans are deterministic. The simulation waits for every replan (no
latency modelled); the CPU seconds of each replan are recorded (median, largest) so its latency
shows.

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan_push.py [--cases flat_trot pallet_walk] [--period 0.25]
        [--loops open closed] [--track-violation X] [--step-adaptation G] [--param KEY=VALUE ...]
        [--model planner|scalar] [--impulses X Y ...] [--result NAME]

`--impulses` runs the listed impulses instead of bracketing (a survival grid: brackets move by a
few N s with any change of a replan's arithmetic, a grid counts survivals over a range).
`--track-violation`, `--step-adaptation` and `--param` (any `ReplanParams` field, e.g.
`tube_velocity=0.3` for event-triggered replans) set the closed loop's `ReplanParams` (recorded in
the JSON as `replan_settings`); each run records its replans' triggers.

Cases: the 1 m flat trot (4 strides, 2.4 s) and the (-1.0, 0.3, 0.3) → (0.6, 0, 0) single pallet
walk (4 strides, 5.5 s) of `bench/sim.py`, planned with `DynParams()` (no costs) on the planner's
model (`--model planner`, `legplan.dyn.tasks.centroidal_model`: the joint torque limits as rows, as
`legplan dyn plan` and `dyn simulate --replan` plan and replan) or TOWR's scalar model (`--model
scalar`, `robot.centroidal`, what this bench used before the torque rows). Writes
bench/results/<NAME>.json (default replan_push.json) (`bench/replan.py`'s BENCHMARKS.md section cites it).
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from common import ROOT, code_version, load_average, machine, write_result  # noqa: E402

PUSH_DURATION = 0.1  # s
PUSH_START = 4.0  # N s, the first impulse tried
CASES = {"flat_trot": ("flat", "flat trot 1 m", ((0, 0, 0), (1.0, 0, 0)), "trot", 2.4, 1.0),
         "pallet_walk": ("single_pallet", "single pallet walk", ((-1.0, 0.3, 0.3), (0.6, 0, 0)), "walk", 5.5, 1.0)}
"""name: (map, label, (start, goal), gait, duration s, resolution N s)."""


def bracket(survives, resolution: float, most: float) -> tuple[float, float, list]:
    """(largest survived impulse, smallest failed one or inf, runs): doubling from `PUSH_START`
    until a run fails (or `most` N s survives), then bisection to `resolution`."""
    runs = [survives(0.0)]
    if not runs[0]["success"]:
        return float("nan"), 0.0, runs
    low, high = 0.0, PUSH_START
    while True:
        runs.append(survives(high))
        if not runs[-1]["success"]:
            break
        if high >= most:
            return high, float("inf"), runs
        low, high = high, 2 * high
    while high - low > resolution:
        middle = 0.5 * (low + high)
        runs.append(survives(middle))
        low, high = (middle, high) if runs[-1]["success"] else (low, middle)
    return low, high, runs


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", nargs="+", choices=tuple(CASES), default=list(CASES))
    parser.add_argument("--period", type=float, default=0.25, help="s between replans")
    parser.add_argument("--most", type=float, default=64.0, help="N s: stop doubling once this survives")
    parser.add_argument("--loops", nargs="+", choices=("open", "closed"), default=["open", "closed"])
    parser.add_argument("--resolution", type=float, default=None, help="N s: bisection stop (default: the case's)")
    parser.add_argument("--track-violation", type=float, default=None, help="ReplanParams.track_violation")
    parser.add_argument("--step-adaptation", type=float, default=None, help="ReplanParams.step_adaptation")
    parser.add_argument("--param", action="append", default=[], metavar="KEY=VALUE",
                        help="a ReplanParams field (legplan.dyn.replan), e.g. tube_velocity=0.3; repeatable")
    parser.add_argument("--model", choices=("planner", "scalar"), default="planner",
                        help="planner: centroidal_model (torque rows), as the CLI; scalar: robot.centroidal")
    parser.add_argument("--impulses", type=float, nargs="+", default=None,
                        help="N s: run these impulses (a survival grid) instead of bracketing")
    parser.add_argument("--result", default="replan_push", help="bench/results/<name>.json")
    args = parser.parse_args()

    from legplan.dyn.planner import plan
    from legplan.dyn.problem import DynParams, DynTask
    from legplan.dyn.replan import Previous, ReplanParams
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.sim.replanning import Replanner
    from legplan.sim.run import SimParams, simulate
    from legplan.specio import apply_overrides
    from legplan.terrain.spec import build_map

    load_start = load_average()
    started = time.perf_counter()
    robot = load_robot("anymal")
    params = DynParams()
    model = centroidal_model(robot, params) if args.model == "planner" else robot.centroidal
    chosen = {"track_violation": args.track_violation, "step_adaptation": args.step_adaptation}
    settings = apply_overrides(ReplanParams(**{k: v for k, v in chosen.items() if v is not None}),
                               dict(item.split("=", 1) for item in args.param), "--param", "replan")
    rows = []
    for name in args.cases:
        map_name, label, (start, goal), gait, duration, resolution = CASES[name]
        resolution = args.resolution or resolution
        terrain_map = build_map(ROOT / "maps" / f"{map_name}.yaml")
        terrain = TerrainModel(terrain_map)
        planned = plan(DynTask(start, goal, gait, 4, duration), model, terrain, params)
        print(f"{label}: plan {planned.status.name}", file=sys.stderr, flush=True)
        for loop in args.loops:
            def survives(impulse: float) -> dict:
                pushes = ((duration / 2, 0.0, impulse / PUSH_DURATION, PUSH_DURATION),) if impulse > 0 else ()
                replanner = (Replanner(Previous.from_plan(planned), model, terrain, params, args.period,
                                       settings)
                             if loop == "closed" else None)
                result = simulate(planned.samples, robot, terrain_map, SimParams(pushes=pushes), goal=goal,
                                  replanner=replanner)
                replans = result.replans
                cpu = np.asarray(replans.get("cpu_seconds", []), float)
                run = {"impulse": impulse, "success": result.success, "reason": result.reason,
                       "replans": int(cpu.size), "replans_converged": int(np.sum(replans.get("success", []))),
                       "replans_tracked": int(np.sum(replans.get("tracked", []))),
                       "replans_tube": int(np.sum(np.asarray(replans.get("trigger", []), bytes) == b"tube")),
                       "replans_time_limit": int(np.sum(np.asarray(replans.get("status", []), bytes) == b"time_limit")),
                       "extension": float(np.sum(replans.get("extension", []))),
                       "replan_cpu_median": float(np.median(cpu)) if cpu.size else None,
                       "replan_cpu_max": float(cpu.max()) if cpu.size else None, "wall": result.wall}
                print(f"  {label} {loop} {impulse:.2f} N s: {result.reason}; replans {run['replans_converged']}/"
                      f"{run['replans']} (tracked {run['replans_tracked']})", file=sys.stderr, flush=True)
                return run
            if args.impulses:
                runs = [survives(impulse) for impulse in args.impulses]
                rows.append({"case": label, "loop": loop, "planned": bool(planned.success), "push_at": duration / 2,
                             "survived_count": sum(run["success"] for run in runs), "runs": runs})
                continue
            low, high, runs = bracket(survives, resolution, args.most)
            rows.append({"case": label, "loop": loop, "planned": bool(planned.success), "push_at": duration / 2,
                         "survived": low, "failed": high, "runs": runs})
    path = write_result(args.result, {
        "date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
        "load_start": load_start, "load_end": load_average(), "wall": time.perf_counter() - started,
        "period": args.period, "model": args.model, "replan_settings": vars(settings), "push_duration": PUSH_DURATION, "rows": rows})
    for row in rows:
        if "survived_count" in row:
            print(f"{row['case']}, {row['loop']} loop: survived {row['survived_count']} of {len(row['runs'])} impulses: "
                  + " ".join(f"{run['impulse']:g}{'+' if run['success'] else '-'}" for run in row["runs"]))
            continue
        print(f"{row['case']}, {row['loop']} loop: survived {row['survived']:.2f} N s, failed {row['failed']:.2f} N s")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
