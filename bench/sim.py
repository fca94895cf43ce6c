"""Benchmark of physics execution (`legplan.sim`, issue 17): QP solvers, simulator speed, and success and
tracking of planned trajectories with vs without the TOWR-costs paper's costs (its Fig. 4 (e)-(f)).

    .venv/bin/python bench/sim.py [--no-append] [--from-json]

* Tasks: flat ground (trot, 4 strides, 2.4 s: 1 m, 0.5 m, 0.6 m diagonal, 1 m with a 0.5 rad turn) and
  the Single Pallet (walk, 4 strides, 5.5 s, from (-1.0, 0.3, 0.3) and (-0.8, -0.2, 0) to (0.6, 0, 0),
  the paper's Sec. V-2 task), each planned by `legplan.dyn.planner.plan` without costs (TOWR's
  formulation, `DynParams()`) and with them (`PAPER`), the pallet tasks also with the paper's settings
  and the legs kept 6 cm off the terrain (`leg_clearance`, ours), then executed by `legplan.sim.simulate`
  (ANYmal at its URDF's 40 N m, μ = 0.5 as planned). Success, fall time, rms/max base position and
  orientation tracking errors, peak torque and torque saturation per run; a failed run is executed
  again with twice the torque limits (`ModelOptions.effort_scale`), to tell torque-limited plans apart.
* QP solvers on the controller's QPs: every 4th tick's QP of the 1 m flat trot's run, rebuilt from
  its recorded states, solved cold by ProxQP (proxsuite, dense backend, eps_abs 1e-6: the
  controller's) and by OSQP (setup + solve, eps_abs = eps_rel = 1e-6, polished): median and max
  wall time per QP, and the worst residual of the floating-base dynamics equality and of the torque
  limits at the answers. OSQP is a bench-only import: `.venv/bin/pip install osqp==1.1.3`.
* Simulator speed: simulated seconds per CPU second of `simulate` over all runs (400 Hz control,
  0.5 ms physics; CPU rather than wall time: the machine is shared).

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
from legplan.dyn.terrain import TerrainModel
from legplan.robots import load_robot
from legplan.sim.controller import WholeBodyController
from legplan.sim.model import ModelOptions, build_model
from legplan.sim.reference import Reference
from legplan.sim.run import SimParams, simulate
from legplan.terrain.spec import build_map

FLAT = [((0, 0, 0), (1.0, 0, 0)), ((0, 0, 0), (0.5, 0, 0)), ((0, 0, 0), (0.6, 0.6, 0)), ((0, 0, 0), (1.0, 0, 0.5))]
PALLET = [((-1.0, 0.3, 0.3), (0.6, 0, 0)), ((-0.8, -0.2, 0.0), (0.6, 0, 0))]


SETTINGS = {"none": DynParams(), "paper": PAPER, "paper, legs 6 cm": replace(PAPER, leg_clearance=0.06)}


def run_tasks(robot, terrain_map, tasks, gait, duration, labels):
    terrain = TerrainModel(terrain_map)
    rows = []
    for start, goal in tasks:
        for label in labels:
            params = SETTINGS[label]
            task = DynTask(start, goal, gait, 4, duration)
            planned = plan(task, robot.centroidal, terrain, params)
            row = {"map": terrain_map.name, "start": start, "goal": goal, "costs": label,
                   "planned": bool(planned.success)}
            cpu = time.process_time()
            result = simulate(planned.samples, robot, terrain_map, SimParams(), goal=goal)
            cpu = time.process_time() - cpu
            if not result.success:   # what-if: the same plan with twice the URDF's joint torque limits
                row["success_at_2x_torque"] = simulate(planned.samples, robot, terrain_map,
                                                       SimParams(model=ModelOptions(effort_scale=2.0)), goal=goal).success
            row.update({"success": result.success, "reason": result.reason, "fall_time": result.fall_time,
                        "rms_position_error": result.rms_position_error,
                        "max_position_error": result.max_position_error,
                        "rms_orientation_error": result.rms_orientation_error,
                        "max_orientation_error": result.max_orientation_error,
                        "peak_torque": result.peak_torque, "saturation": result.saturation,
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
    controller = WholeBodyController(robot, sim.effort, robot.centroidal.friction)
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
    import proxsuite

    times, worst = [], 0.0
    for qp in qps:
        t0 = time.perf_counter()
        solver = proxsuite.proxqp.dense.QP(len(qp.g), len(qp.b), len(qp.l))
        solver.settings.eps_abs = 1e-6
        solver.settings.verbose = False
        solver.init(qp.H, qp.g, qp.A, qp.b, qp.C, qp.l, qp.u)
        solver.solve()
        times.append(time.perf_counter() - t0)
        worst = max(worst, judge(qp, solver.results.x, n_joints))
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
    args = parser.parse_args()
    if args.from_json:
        update_benchmarks("sim", markdown(json.loads((ROOT / "bench" / "results" / "sim.json").read_text())))
        return
    robot = load_robot("anymal")
    load_start = load_average()
    maps = {name: build_map(ROOT / "maps" / f"{name}.yaml") for name in ("flat", "single_pallet")}
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
    return "\n".join(lines)


if __name__ == "__main__":
    main()
