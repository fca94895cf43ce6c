"""Benchmark of physics execution (`legplan.sim`, issue 17): QP solvers, simulator speed, and success and
tracking of planned trajectories with vs without the TOWR-costs paper's costs (its Fig. 4 (e)-(f)).

    .venv/bin/python bench/sim.py [--no-append] [--from-json]

* Tasks: flat ground (trot, 4 strides, 2.4 s: 1 m, 0.5 m, 0.6 m diagonal, 1 m with a 0.5 rad turn) and
  the Single Pallet (walk, 4 strides, 5.5 s, from (-1.0, 0.3, 0.3) and (-0.8, -0.2, 0) to (0.6, 0, 0),
  the paper's Sec. V-2 task), each planned by `legplan.dyn.planner.plan` on the planner's model
  (`legplan.dyn.tasks.centroidal_model`: the URDF's joint torque limits as rows, as `legplan dyn
  plan`) without costs (TOWR's formulation, `DynParams()`) and with them (`PAPER`), the pallet tasks also with the paper's settings
  and the legs kept 6 cm off the terrain (`leg_clearance`, ours), then executed by `legplan.sim.simulate`
  (ANYmal at its URDF's 40 N m, μ = 0.5 as planned). Success, fall time, rms/max base position and
  orientation tracking errors, peak torque and torque saturation per run; a failed run is executed
  again with twice the torque limits (`ModelOptions.effort_scale`), to tell torque-limited plans apart.
* QP solvers on the controller's QPs: every 4th tick's QP of the 1 m flat trot's run, rebuilt from
  its recorded states, solved cold by ProxQP (proxsuite, dense backend, the controller's
  `solve_qp`) and by OSQP (setup + solve, eps_abs = eps_rel = 1e-6, polished): median and max
  wall time per QP, and the worst residual of the floating-base dynamics equality and of the torque
  limits at the answers. OSQP is a bench-only import: `.venv/bin/pip install osqp==1.1.3`.
* Simulator speed: simulated seconds per CPU second of `simulate` over all runs (400 Hz control,
  0.5 ms physics; CPU rather than wall time: the machine is shared).
* Robustness (`--push-only` runs just this part, kept in the JSON's `push` entry): the largest
  lateral push survived (+y, on the trunk, `SimParams.pushes`) during the 1 m flat trot and the
  (-1.0, 0.3, 0.3) single pallet walk, planned without and with the paper's costs, open loop (the
  plan is not replanned; the controller tracks it as planned). The push lasts `PUSH_DURATION` and
  starts at half the plan's duration; its impulse is bisected: doubled from `PUSH_START` until a
  run fails, then halved until the bracket is narrower than the resolution. Survived = reached the
  goal without falling. Every run's QP failures (relaxed-QP fallbacks) and held ticks are recorded.

* Limits and model error (`--limits-only`, the JSON's `limits` entry): the double pallet walk
  (-1, 0, 0) → (1, 0, 0) in 5.5 s executed under the URDF's 8 rad/s joint velocity limit (peak joint
  speed over the limit at any 400 Hz tick, time at the limit, time more than 5 % over it), and the
  1 m flat trot with the simulated friction × 0.6 and the masses × 1.2 (the controller keeps the
  plan's μ and the URDF's masses), each without and with the paper's costs.

Writes bench/results/sim.json and replaces the `sim` section of BENCHMARKS.md.
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
import time
from dataclasses import replace

import numpy as np
import pinocchio as pin

from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result

from legplan.dyn.planner import plan
from legplan.dyn.problem import PAPER, DynParams, DynTask
from legplan.dyn.tasks import centroidal_model
from legplan.dyn.terrain import TerrainModel
from legplan.robots import load_robot
from legplan.sim.controller import WholeBodyController, solve_qp
from legplan.sim.model import ModelOptions, build_model
from legplan.sim.reference import Reference
from legplan.sim.run import SimParams, simulate
from legplan.terrain.spec import build_map

FLAT = [((0, 0, 0), (1.0, 0, 0)), ((0, 0, 0), (0.5, 0, 0)), ((0, 0, 0), (0.6, 0.6, 0)), ((0, 0, 0), (1.0, 0, 0.5))]
PALLET = [((-1.0, 0.3, 0.3), (0.6, 0, 0)), ((-0.8, -0.2, 0.0), (0.6, 0, 0))]


SETTINGS = {"none": DynParams(), "paper": PAPER, "paper, legs 6 cm": replace(PAPER, leg_clearance=0.06)}
PUSH_DURATION = 0.1        # s
PUSH_START = 4.0           # N s, the first impulse tried
PUSH_CASES = [("flat", "flat trot 1 m", FLAT[0], "trot", 2.4, 0.5, ("none", "paper")),
              ("single_pallet", "single pallet walk", PALLET[0], "walk", 5.5, 1.0, ("none", "paper"))]
"""(map, label, (start, goal), gait, duration s, resolution N s, cost settings) of the push bisection."""


def push_run(robot, terrain_map, samples, goal, at, impulse):
    """One run with a lateral push of `impulse` N s at `at` s: its outcome and QP counts."""
    pushes = ((at, 0.0, impulse / PUSH_DURATION, PUSH_DURATION),) if impulse > 0 else ()
    result = simulate(samples, robot, terrain_map, SimParams(pushes=pushes), goal=goal)
    print(f"  push {impulse:.2f} N s: {result.reason}; QP failures {result.qp_failures}, held {result.qp_held}",
          file=sys.stderr)
    return {"impulse": impulse, "success": result.success, "reason": result.reason,
            "qp_failures": result.qp_failures, "qp_held": result.qp_held, "wall": result.wall}


def largest_push(robot, terrain_map, samples, goal, at, resolution):
    """Bisection of the module docstring: (largest survived impulse, smallest failed one, runs)."""
    runs = [push_run(robot, terrain_map, samples, goal, at, 0.0)]
    if not runs[0]["success"]:
        return float("nan"), 0.0, runs
    low, high = 0.0, PUSH_START
    while True:
        runs.append(push_run(robot, terrain_map, samples, goal, at, high))
        if not runs[-1]["success"]:
            break
        low, high = high, 2 * high
    while high - low > resolution:
        middle = 0.5 * (low + high)
        runs.append(push_run(robot, terrain_map, samples, goal, at, middle))
        low, high = (middle, high) if runs[-1]["success"] else (low, middle)
    return low, high, runs


LIMIT_CASES = [("double_pallet", "double pallet walk", ((-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)), "walk", 5.5, {}),
               ("flat", "flat trot 1 m, friction × 0.6", FLAT[0], "trot", 2.4, {"friction_scale": 0.6}),
               ("flat", "flat trot 1 m, masses × 1.2", FLAT[0], "trot", 2.4, {"mass_scale": 1.2})]


def limits_bench(robot, maps):
    rows = []
    for map_name, label, (start, goal), gait, duration, perturbation in LIMIT_CASES:
        terrain = TerrainModel(maps[map_name])
        for costs in ("none", "paper"):
            planned = plan(DynTask(start, goal, gait, 4, duration), centroidal_model(robot, SETTINGS[costs]), terrain,
                           SETTINGS[costs])
            result = simulate(planned.samples, robot, maps[map_name], SimParams(**perturbation), goal=goal)
            print(f"{label}, costs {costs}: {result.reason}; speed × {result.peak_speed_ratio:.2f} of the limit",
                  file=sys.stderr)
            rows.append({"case": label, "costs": costs, "planned": bool(planned.success), "success": result.success,
                         "reason": result.reason, "peak_speed_ratio": result.peak_speed_ratio,
                         "speed_limited_time": result.speed_limited_time, "overspeed_time": result.overspeed_time,
                         "qp_failures": result.qp_failures, "qp_held": result.qp_held,
                         "rms_position_error": result.rms_position_error})
    return rows


def push_bench(robot, maps):
    rows = []
    for map_name, label, (start, goal), gait, duration, resolution, settings in PUSH_CASES:
        terrain = TerrainModel(maps[map_name])
        for costs in settings:
            planned = plan(DynTask(start, goal, gait, 4, duration), centroidal_model(robot, SETTINGS[costs]), terrain,
                           SETTINGS[costs])
            print(f"{label}, costs {costs}: plan {'ok' if planned.success else 'FAILED'}", file=sys.stderr)
            low, high, runs = largest_push(robot, maps[map_name], planned.samples, goal, duration / 2, resolution)
            rows.append({"case": label, "costs": costs, "planned": bool(planned.success), "push_at": duration / 2,
                         "survived": low, "failed": high, "runs": runs})
    return rows


def run_tasks(robot, terrain_map, tasks, gait, duration, labels):
    terrain = TerrainModel(terrain_map)
    rows = []
    for start, goal in tasks:
        for label in labels:
            params = SETTINGS[label]
            task = DynTask(start, goal, gait, 4, duration)
            planned = plan(task, centroidal_model(robot, params), terrain, params)
            row = {"map": terrain_map.name, "start": start, "goal": goal, "costs": label,
                   "planned": bool(planned.success)}
            cpu = time.process_time()
            result = simulate(planned.samples, robot, terrain_map, SimParams(), goal=goal)
            cpu = time.process_time() - cpu
            if not result.success:   # what-if: the same plan with twice the URDF's joint torque limits
                twice = SimParams(model=ModelOptions(effort_scale=2.0))
                row["success_at_2x_torque"] = simulate(planned.samples, robot, terrain_map, twice, goal=goal).success
            row.update({"success": result.success, "reason": result.reason, "fall_time": result.fall_time,
                        "rms_position_error": result.rms_position_error,
                        "max_position_error": result.max_position_error,
                        "rms_orientation_error": result.rms_orientation_error,
                        "max_orientation_error": result.max_orientation_error,
                        "peak_torque": result.peak_torque, "saturation": result.saturation,
                        "qp_failures": result.qp_failures, "qp_held": result.qp_held,
                        "simulated": result.simulated, "wall": result.wall, "cpu": cpu, "result": result,
                        "samples": planned.samples})
            print(f"{terrain_map.name} {start}->{goal} {label}: {result.reason}; rms {result.rms_position_error:.3f} m "
                  f"{result.rms_orientation_error:.3f} rad", file=sys.stderr)
            rows.append(row)
    return rows


def collect_qps(robot, terrain_map, row, every=4):
    """The controller's QPs at the recorded states of one run (rows every 10 ms, every `every`-th)."""
    sim = build_model(robot, terrain_map, robot.centroidal.friction)
    reference = Reference(row["samples"], sim.foot_radius, TerrainModel(terrain_map))
    controller = WholeBodyController(robot, sim.effort, robot.centroidal.friction, velocity_limit=sim.velocity_limit,
                                     damping=sim.damping, armature=sim.armature)
    series = row["result"].series
    qps = []
    for k in range(0, len(series["t"]), every):
        q = np.concatenate([series["base_pos"][k], series["base_quat"][k], series["joint_pos"][k]])
        rot = pin.Quaternion(series["base_quat"][k]).normalized().matrix()
        v = np.concatenate([rot.T @ series["base_vel"][k], rot.T @ series["base_ang_vel"][k], series["joint_vel"][k]])
        touching = series["foot_forces"][k][:, 2] > 0
        qps.append(controller.build(q, v, reference.at(series["t"][k]), touching))
    return qps


def judge(qp, x, n_joints):
    return max(float(np.abs(qp.A[:6] @ x - qp.b[:6]).max()),
               float(np.maximum(qp.C[:n_joints] @ x - qp.u[:n_joints], qp.l[:n_joints] - qp.C[:n_joints] @ x).max()))


def time_proxqp(qps, n_joints):
    times, worst = [], 0.0
    for qp in qps:
        t0 = time.perf_counter()
        x, _ = solve_qp(qp)
        times.append(time.perf_counter() - t0)
        worst = max(worst, judge(qp, x, n_joints))
    return times, worst


def time_osqp(qps, n_joints):
    import osqp
    import scipy.sparse as sp

    times, worst = [], 0.0
    for qp in qps:
        t0 = time.perf_counter()
        solver = osqp.OSQP()
        solver.setup(P=sp.csc_matrix(np.triu(qp.H)), q=qp.g, A=sp.csc_matrix(np.vstack([qp.A, qp.C])),
                     l=np.concatenate([qp.b, qp.l]), u=np.concatenate([qp.b, qp.u]), eps_abs=1e-6, eps_rel=1e-6,
                     polishing=True, verbose=False, max_iter=20000)
        result = solver.solve()
        times.append(time.perf_counter() - t0)
        worst = max(worst, judge(qp, result.x, n_joints))
    return times, worst


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--no-append", action="store_true", help="do not touch BENCHMARKS.md")
    parser.add_argument("--from-json", action="store_true", help="rewrite the section from bench/results/sim.json")
    parser.add_argument("--push-only", action="store_true",
                        help="run only the push bisection; keep the other results of bench/results/sim.json")
    parser.add_argument("--limits-only", action="store_true",
                        help="run only the limits / model-error runs; keep the other results of bench/results/sim.json")
    args = parser.parse_args()
    if args.from_json:
        update_benchmarks("sim", markdown(json.loads((ROOT / "bench" / "results" / "sim.json").read_text())))
        return
    robot = load_robot("anymal")
    load_start = load_average()
    maps = {name: build_map(ROOT / "maps" / f"{name}.yaml") for name in ("flat", "single_pallet", "double_pallet")}
    if args.push_only or args.limits_only:
        result = json.loads((ROOT / "bench" / "results" / "sim.json").read_text())
        started = time.perf_counter()
        rows = push_bench(robot, maps) if args.push_only else limits_bench(robot, maps)
        result["push" if args.push_only else "limits"] = {
            "commit": code_version(), "date": str(datetime.date.today()), "load_start": load_start,
            "load_end": load_average(), "wall": time.perf_counter() - started, "rows": rows}
        write_result("sim", result)
        if not args.no_append:
            update_benchmarks("sim", markdown(result))
        print(markdown(result))
        return
    rows = run_tasks(robot, maps["flat"], FLAT, "trot", 2.4, ("none", "paper")) + \
        run_tasks(robot, maps["single_pallet"], PALLET, "walk", 5.5, tuple(SETTINGS))
    qps = collect_qps(robot, maps["flat"], rows[0])
    prox_times, prox_worst = time_proxqp(qps, robot.n_joints)
    osqp_times, osqp_worst = time_osqp(qps, robot.n_joints)
    speed = sum(r["simulated"] for r in rows) / sum(r["cpu"] for r in rows)
    commit = code_version()
    for row in rows:
        row.pop("result"), row.pop("samples")
    result = {"machine": machine(), "commit": commit, "load_start": load_start, "load_end": load_average(),
              "runs": rows, "speed": speed,
              "qp": {"count": len(qps), "proxqp_median_ms": 1e3 * np.median(prox_times),
                     "proxqp_max_ms": 1e3 * max(prox_times), "proxqp_worst_residual": prox_worst,
                     "osqp_median_ms": 1e3 * np.median(osqp_times), "osqp_max_ms": 1e3 * max(osqp_times),
                     "osqp_worst_residual": osqp_worst}}
    previous = ROOT / "bench" / "results" / "sim.json"
    for part in ("push", "limits"):   # measured apart (--push-only, --limits-only)
        if previous.exists() and part in json.loads(previous.read_text()):
            result[part] = json.loads(previous.read_text())[part]
    write_result("sim", result)
    if not args.no_append:
        update_benchmarks("sim", markdown(result))
    print(markdown(result))


def markdown(result) -> str:
    qp = result["qp"]
    lines = [f"## sim — planned trajectories executed in MuJoCo by the whole-body controller "
             f"({datetime.date.today()}, {result['machine']}, {result['commit']}, load {result['load_start']:.1f} → "
             f"{result['load_end']:.1f})", "",
             "ANYmal at its URDF's 40 N m, μ = 0.5 as planned, 400 Hz control; success = no fall and the base "
             "within 10 cm / 0.2 rad of the goal after 0.5 s settling (`bench/sim.py`).", "",
             "| map | start → goal | costs | plan ok | sim | rms pos (m) | max pos (m) | rms rot (rad) | "
             "max rot (rad) | peak τ (N m) | τ saturated |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for r in result["runs"]:
        outcome = "success" if r["success"] else ("fell %.2f s" % r["fall_time"] if np.isfinite(r["fall_time"])
                                                 else "missed goal")
        if not r["success"]:
            outcome += "; at 80 N m: " + ("success" if r["success_at_2x_torque"] else "fails")
        lines.append(f"| {r['map']} | {tuple(r['start'])} → {tuple(r['goal'])} | {r['costs']} | {r['planned']} | "
                     f"{outcome} | {r['rms_position_error']:.3f} | {r['max_position_error']:.3f} | "
                     f"{r['rms_orientation_error']:.3f} | {r['max_orientation_error']:.3f} | {r['peak_torque']:.0f} | "
                     f"{100 * r['saturation']:.0f} % |")
    for label in dict.fromkeys(r["costs"] for r in result["runs"]):
        runs = [r for r in result["runs"] if r["costs"] == label]
        lines.append(f"\n{label}: {sum(r['success'] for r in runs)}/{len(runs)} succeeded, median rms position error "
                     f"{np.median([r['rms_position_error'] for r in runs]):.3f} m, orientation "
                     f"{np.median([r['rms_orientation_error'] for r in runs]):.3f} rad.")
    failed = [r for r in result["runs"] if not r["success"]]
    lines.append(f"\nFailed runs that succeed with twice the torque limits (80 N m): "
                 f"{sum(r['success_at_2x_torque'] for r in failed)}/{len(failed)} — those plans ask for more "
                 f"joint torque than the URDF's 40 N m (the 'τ saturated' column: ticks with a joint at its limit). "
                 f"'plan ok' False: the optimizer reported failure, its last samples were executed anyway.")
    lines += ["", f"Simulator speed: {result['speed']:.2f} simulated s per CPU s (all runs; model build, leg IK, "
              f"controller and physics).",
              "", f"QP solvers on {qp['count']} of the controller's QPs (1 m flat trot, cold start each):", "",
              "| solver | median (ms) | max (ms) | worst dynamics/torque residual |", "|---|---|---|---|",
              f"| ProxQP 0.8.0 (dense) | {qp['proxqp_median_ms']:.3f} | {qp['proxqp_max_ms']:.3f} | "
              f"{qp['proxqp_worst_residual']:.1e} |",
              f"| OSQP 1.1.3 (sparse ADMM, polished) | {qp['osqp_median_ms']:.3f} | {qp['osqp_max_ms']:.3f} | "
              f"{qp['osqp_worst_residual']:.1e} |"]
    if "qp_failures" in result["runs"][0]:
        lines += ["", "QP failures (ticks whose QP was not solved: the relaxed QP ran) / held ticks per run, in "
                  "table order: " + ", ".join(f"{r['qp_failures']}/{r['qp_held']}" for r in result["runs"]) + "."]
    if "push" in result:
        lines += push_markdown(result["push"])
    if "limits" in result:
        lines += limits_markdown(result["limits"])
    return "\n".join(lines)


def limits_markdown(limits) -> list[str]:
    lines = ["", f"### Joint velocity limits and model error ({limits['date']}, {limits['commit']}, load "
             f"{limits['load_start']:.1f} → {limits['load_end']:.1f})", "",
             "ANYmal's URDF limit 8 rad/s on every joint, enforced by the motors (no driving torque at the limit) "
             "and the controller (rates one 10 ms horizon ahead inside the limit); 'peak speed' is the largest "
             "|joint rate| / limit at any 400 Hz tick; 'over 5 %' is the time a joint spent more than 5 % over its "
             "limit (impacts back-driving a joint).", "",
             "| run | costs | plan ok | sim | rms pos (m) | peak speed / limit | at limit (s) | over 5 % (s) | "
             "QP failures / held |", "|---|---|---|---|---|---|---|---|---|"]
    for r in limits["rows"]:
        outcome = "success" if r["success"] else r["reason"].split(":")[0]
        lines.append(f"| {r['case']} | {r['costs']} | {r['planned']} | {outcome} | {r['rms_position_error']:.3f} | "
                     f"{r['peak_speed_ratio']:.2f} | {r['speed_limited_time']:.3f} | {r['overspeed_time']:.3f} | "
                     f"{r['qp_failures']} / {r['qp_held']} |")
    return lines


def push_markdown(push) -> list[str]:
    lines = ["", f"### Largest lateral push survived (open loop; {push['date']}, {push['commit']}, load "
             f"{push['load_start']:.1f} → {push['load_end']:.1f}, {push['wall'] / 60:.0f} min wall)", "",
             f"A +y force on the trunk for {PUSH_DURATION} s from half the plan's duration; its impulse bisected "
             "(doubled from 4 N s until a run fails, then halved to the resolution); survived = goal reached "
             "without a fall; the plan is not replanned. One run per impulse: MuJoCo and the controller are "
             "deterministic, so the bracket does not depend on the machine's load.", "",
             "| task | costs | plan ok | survived (N s) | failed (N s) | runs | QP failures / held (all runs) |",
             "|---|---|---|---|---|---|---|"]
    for r in push["rows"]:
        survived = f"{r['survived']:.2f}" if np.isfinite(r["survived"]) else "— (falls unpushed)"
        lines.append(f"| {r['case']} | {r['costs']} | {r['planned']} | {survived} | {r['failed']:.2f} | "
                     f"{len(r['runs'])} | {sum(x['qp_failures'] for x in r['runs'])} / "
                     f"{sum(x['qp_held'] for x in r['runs'])} |")
    return lines


if __name__ == "__main__":
    main()
