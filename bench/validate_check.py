"""Cost of the independent validator on a dense re-sampling of one step (the Bézier planner checks
>= 1000 configurations per step).

For n configurations of scarab2 near the gap-crossing beam/pillar (random joints around nominal,
body heights close to the terrain so many spheres are near it) it times
  ours:      Validator.check (pinocchio FK per configuration, CoM margin, clearance with distance
             bounds so that only candidate spheres go to FCL);
  reference: the same FK, then fcl.distance for every sphere of every configuration (brute force).
Median of several runs; writes bench/results/validate_check.json and updates its section of BENCHMARKS.md.
    .venv/bin/python bench/validate_check.py [--n 1000] [--repeats 5] [--no-append]
"""

from __future__ import annotations

import argparse
import datetime
import json
import time

import numpy as np

from common import ROOT, load_average, machine, update_benchmarks, write_result

from legplan.robots import load_robot
from legplan.terrain import build_map
from legplan.validate import Validator



def configurations(robot, n, rng):
    Q = np.repeat(robot.q_nominal[None], n, axis=0)
    Q[:, 0] = rng.uniform(-0.35, 0.35, n)
    Q[:, 2] += rng.uniform(-0.02, 0.04, n)
    Q[:, 7:] += rng.uniform(-0.3, 0.3, (n, robot.n_joints))
    stance = np.ones((n, robot.n_legs), bool)
    stance[:, 1] = False
    footholds = np.repeat(robot.foot_positions(robot.q_nominal), n, axis=0)  # one step: fixed footholds
    return Q, stance, footholds


def main() -> None:
    parser = argparse.ArgumentParser()
    parser.add_argument("--n", type=int, default=1000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--no-append", action="store_true")
    args = parser.parse_args()
    robot = load_robot("scarab2")
    terrain = build_map(ROOT / "maps" / "gap_crossing.yaml")
    t0 = time.perf_counter()
    validator = Validator(robot, terrain)
    build = time.perf_counter() - t0
    Q, stance, footholds = configurations(robot, args.n, np.random.default_rng(0))
    ours, brute = [], []
    for _ in range(args.repeats):
        t0 = time.perf_counter()
        checks = validator.check(Q, stance, footholds)
        ours.append(time.perf_counter() - t0)
    for _ in range(max(1, args.repeats // 2)):
        t0 = time.perf_counter()
        _, centres, _ = validator.kinematics(Q)
        d = validator.surface.fcl_distance(centres.reshape(-1, 3)).reshape(args.n, -1) - robot.spheres.radii
        brute.append(time.perf_counter() - t0)
    exempt = stance[:, robot.spheres.leg_index] & robot.spheres.is_foot
    exempt[:, robot.spheres.leg_index < 0] = False
    d[exempt] = np.inf
    assert np.allclose(d.min(axis=1), checks.clearance, atol=1e-9)
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "load_average": load_average(),
              "n": args.n, "spheres": len(robot.spheres), "mesh_build_s": build,
              "ours_s": float(np.median(ours)), "brute_force_fcl_s": float(np.median(brute)),
              "ratio": float(np.median(brute) / np.median(ours))}
    write_result("validate_check", result)
    print(json.dumps(result, indent=2))
    if not args.no_append:
        update_benchmarks("validate_check",
                          f"## validator dense check ({result['date']}, {result['machine']}, "
                          f"load {result['load_average']:.1f})\n\n"
                    f"scarab2 on gap_crossing: Validator.check of {args.n} configurations (28 spheres), "
                    f"median of {args.repeats} runs: {result['ours_s'] * 1e3:.0f} ms "
                    f"({result['ours_s'] / args.n * 1e6:.0f} µs/configuration) vs "
                    f"{result['brute_force_fcl_s'] * 1e3:.0f} ms (reference: FK + fcl.distance for every "
                    f"sphere), ratio {result['ratio']:.1f}x; FCL column mesh built once in "
                    f"{build * 1e3:.0f} ms.\n")


if __name__ == "__main__":
    main()
