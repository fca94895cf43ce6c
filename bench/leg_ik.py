"""The joint-torque rows' leg IK with and without the closed-form start (issue 38, the solve's CPU).

    OMP_NUM_THREADS=1 .venv/bin/python bench/leg_ik.py [--rounds 5] [--no-append]

Builds bench/dyn.py's flat trot on the planner's model (`legplan.dyn.tasks.centroidal_model`, the
joint-torque rows included, as `legplan dyn plan` solves) and evaluates its four `JointTorqueBlock`s
along a sequence of ten perturbed points (an LM run's steps: each evaluation starts from the last
one's joints), residuals alone and with Jacobians, once with the legs' chains as the planner has them
(`ChainLegs.of_robot`: IK started from `PlanarLegs.joints`) and once with the chain's damped
Gauss–Newton alone (`closed_form=False`), alternated over rounds in one process. Reports the median
CPU milliseconds per leg evaluation and the largest difference of the torques between the two.
Writes bench/results/leg_ik.json and the `leg_ik` section of BENCHMARKS.md.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402

import numpy as np  # noqa: E402

import dyn as bench_dyn  # noqa: E402
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402
from legplan.dyn.init import heuristic  # noqa: E402
from legplan.dyn.legs import ChainLegs  # noqa: E402
from legplan.dyn.problem import DynParams, build_problem  # noqa: E402
from legplan.dyn.tasks import centroidal_model  # noqa: E402
from legplan.dyn.terrain import TerrainModel  # noqa: E402
from legplan.robots import load_robot  # noqa: E402
from legplan.terrain import build_map  # noqa: E402

STEPS = 10  # perturbed points per round
SCALE = 1e-3  # the largest perturbation of every variable (its own units)


def blocks_of(model, case, terrain):
    problem = build_problem(bench_dyn.task_of(case), model, terrain, DynParams(), heuristic)
    base = {v.name: v.value.copy() for v in problem.variables}
    return [k.block for k in problem.constraints if k.name == "joint_torque"], base


def run(blocks, points, jacobians: bool):
    """CPU ms per leg evaluation over the points, and the stacked torques."""
    torques = []
    t0 = time.process_time()
    for values in points:
        for block in blocks:
            torques.append(block.evaluate([values[v] for v in block.variables], jacobians)[0])
    return (time.process_time() - t0) / (len(points) * len(blocks)) * 1e3, np.concatenate(torques)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--no-append", action="store_true")
    args = parser.parse_args()
    load_start = load_average()
    robot = load_robot("anymal")
    model = centroidal_model(robot)
    case = next(c for c in bench_dyn.CASES if c["key"] == "flat_trot")
    terrain = TerrainModel(build_map(ROOT / "maps" / f"{case['map']}.yaml"))
    variants = {"closed_form": model.leg_chains, "chain": ChainLegs.of_robot(robot, closed_form=False)}
    assert all(c.closed_form is not None for c in variants["closed_form"].chains)
    times = {(v, j): [] for v in variants for j in ("residual", "jacobian")}
    difference, samples = 0.0, None
    for r in range(args.rounds):
        order = list(variants) if r % 2 == 0 else list(variants)[::-1]
        answers = {}
        for name in order:
            blocks, base = blocks_of(replace(model, leg_chains=variants[name]), case, terrain)
            samples = blocks[0].n
            points = [{k: v + SCALE * (i + 1) / STEPS * np.random.default_rng((r, i)).standard_normal(v.shape)
                       for k, v in base.items()} for i in range(STEPS)]
            for kind in ("residual", "jacobian"):
                ms, tau = run(blocks, points, kind == "jacobian")
                times[(name, kind)].append(ms)
                answers.setdefault(name, tau)
        difference = max(difference, float(np.abs(answers["closed_form"] - answers["chain"]).max()))
    medians = {f"{v}_{j}_ms": statistics.median(t) for (v, j), t in times.items()}
    result = {"date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"), "machine": machine(),
              "code": code_version(), "load_start": load_start, "load_end": load_average(), "rounds": args.rounds,
              "samples_per_leg": samples, "runs_ms": {f"{v}_{j}": t for (v, j), t in times.items()},
              **medians, "max_torque_difference_nm": difference}
    write_result("leg_ik", result)
    rows = "\n".join(f"| {j} | {medians[f'chain_{j}_ms']:.2f} | {medians[f'closed_form_{j}_ms']:.2f} | "
                     f"{medians[f'closed_form_{j}_ms'] / medians[f'chain_{j}_ms']:.2f} |" for j in ("residual", "jacobian"))
    text = (f"## leg_ik — the joint-torque rows' leg IK, closed-form start against the chain's Gauss–Newton alone "
            f"(`bench/leg_ik.py`, {result['date'][:16]} UTC, {result['machine']}, code {result['code']}, load "
            f"{load_start:.1f} → {result['load_end']:.1f}: shared machine, timings noisy)\n\n"
            f"Flat trot on the planner's model, 4 legs × {samples} samples, {STEPS} perturbed points per round, "
            f"median of {args.rounds} alternated rounds; CPU ms per leg evaluation.\n\n"
            "| evaluation | chain IK alone (reference) | closed-form start | ratio |\n|---|---|---|---|\n"
            f"{rows}\n\nLargest torque difference between the two: {difference:.1e} N m.")
    print(text)
    if not args.no_append:
        update_benchmarks("leg_ik", text)


if __name__ == "__main__":
    main()
