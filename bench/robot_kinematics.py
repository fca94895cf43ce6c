"""Per-configuration cost of the batch kinematics the Bézier step planner evaluates every LM iteration.

For n = 100 configurations of a robot (default scarab2) it times
  ours:      robot.foot_jacobians + robot.sphere_jacobians + robot.com_jacobian (+ positions), one
             pass (pin.computeJointJacobians per configuration, the rest batched numpy);
  reference: the direct pinocchio loop per configuration: computeJointJacobians +
             updateFramePlacements, getFrameJacobian(LOCAL_WORLD_ALIGNED) per foot and per sphere
             frame (shifted to the sphere centre), jacobianCenterOfMass.
Median of several runs; writes bench/results/robot_kinematics.json and updates its section of BENCHMARKS.md.
    .venv/bin/python bench/robot_kinematics.py [--robot scarab2] [--n 100] [--repeats 15] [--no-append]
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time

import numpy as np
import pinocchio as pin

from common import load_average, machine, update_benchmarks, write_result

from legplan.robots import load_robot
from legplan.robots.so3 import skew


def reference_pass(robot, Q):
    """The direct pinocchio way, one frame at a time."""
    model, data = robot.model, robot.model.createData()
    frames, offsets = robot.spheres.frame_ids, robot.spheres.offsets
    out = []
    for q in Q:
        pin.computeJointJacobians(model, data, q)
        pin.updateFramePlacements(model, data)
        feet = [pin.getFrameJacobian(model, data, leg.foot_frame_id, pin.LOCAL_WORLD_ALIGNED)[:3]
                for leg in robot.legs]
        spheres = []
        for f, o in zip(frames, offsets):
            J = pin.getFrameJacobian(model, data, int(f), pin.LOCAL_WORLD_ALIGNED)
            spheres.append(J[:3] - skew(data.oMf[int(f)].rotation @ o) @ J[3:])
        out.append((feet, spheres, pin.jacobianCenterOfMass(model, data, q, False)))
    return out


def ours(robot, batches):
    """The three public calls; alternating batches so each round misses the one-batch cache once."""
    Q = batches.pop(0)
    batches.append(Q)
    return robot.foot_jacobians(Q), robot.sphere_jacobians(Q), robot.com_jacobian(Q)


def median_time(fn, repeats) -> float:
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append(time.perf_counter() - start)
    return float(np.median(times))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="scarab2")
    ap.add_argument("--n", type=int, default=100)
    ap.add_argument("--repeats", type=int, default=15)
    ap.add_argument("--no-append", action="store_true")
    args = ap.parse_args(argv)
    robot = load_robot(args.robot)
    rng = np.random.default_rng(0)
    X = np.tile(robot.to_vector(robot.q_nominal), (args.n, 1))
    X[:, 6:] = rng.uniform(robot.lower, robot.upper, (args.n, robot.n_joints))
    Q = robot.from_vector(X)
    batches = [Q, Q[::-1].copy()]
    ours(robot, batches), reference_pass(robot, Q)     # warm up
    t_ours = median_time(lambda: ours(robot, batches), args.repeats)
    t_ref = median_time(lambda: reference_pass(robot, Q), args.repeats)
    t_tangent = median_time(lambda: robot.tangent_map(X), args.repeats)
    result = {
        "robot": robot.name, "n_configurations": args.n, "repeats": args.repeats,
        "n_feet": robot.n_legs, "n_spheres": len(robot.spheres), "nv": robot.nv,
        "ours_per_config_us": t_ours / args.n * 1e6, "reference_per_config_us": t_ref / args.n * 1e6,
        "tangent_map_per_config_us": t_tangent / args.n * 1e6, "speedup_vs_reference": t_ref / t_ours,
        "machine": machine(), "load_average": load_average(),
        "date": datetime.date.today().isoformat(),
    }
    write_result("robot_kinematics", result)
    row = (f"## robot kinematics ({result['date']}, {result['machine']}, load {result['load_average']:.1f})\n\n"
           f"{robot.name}: foot + sphere + CoM Jacobians (with positions) of {args.n} configurations "
           f"({robot.n_legs} feet, {len(robot.spheres)} spheres, nv {robot.nv}), median of {args.repeats} runs: "
           f"{result['ours_per_config_us']:.1f} µs/configuration (legplan.robots batch) vs "
           f"{result['reference_per_config_us']:.1f} µs (reference: per-frame pinocchio getFrameJacobian loop), "
           f"ratio {result['speedup_vs_reference']:.1f}x; tangent_map {result['tangent_map_per_config_us']:.2f} µs/configuration.\n")
    print(row)
    if not args.no_append:
        update_benchmarks("robot_kinematics", row)
    return 0


if __name__ == "__main__":
    sys.exit(main())
