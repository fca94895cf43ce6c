"""What a replan problem that persists across replans could save (issue 39 item 3): the CPU split of
`bench/replan.py`'s warm replans into building the problem, the first solve on a new solver problem
(every cache, sparsity pattern and CHOLMOD analysis made anew) and the same solve again on the kept
problem (blocks, index caches, assemblers, nonzero pattern and symbolic analysis all reused: the
floor of a persistent replan of that length), with the cost of one Jacobian and one residual on the
kept problem against the length of the rest.

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan_floor.py [--repeats 2] [--result replan_floor] [--no-append]

* The plan and the replans of `bench/replan.py` (its `TASK`, 6 instants in [0.3, T − 0.5] s, unperturbed
  and with +`PUSH_VELOCITY` lateral base velocity; the "projection" warm stage, default
  `ReplanParams`), and 12 unperturbed replans at instants no two of which share a problem structure
  ("distinct", [0.37, 5.03] s: the closed loop's case, where the content caches of the sampled
  structures miss).
* Per replan: the CPU seconds (process time, one thread) of `build_problem`; of the replan's hinged
  LM (its first outer iteration, which is the whole solve of every replan here that converges) on a
  new `Problem`; of the same LM from the same start on the kept `Problem`, the smallest of
  `--repeats`; and of one Jacobian (`nonzero_jacobian`) and one residual on the kept problem.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import time  # noqa: E402
from dataclasses import replace  # noqa: E402

import numpy as np  # noqa: E402

from common import code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402
from replan import PUSH_VELOCITY, TASK, pallet_plan  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=2, help="solves on the kept problem (the smallest counts)")
    parser.add_argument("--result", default="replan_floor")
    parser.add_argument("--no-append", action="store_true", help="do not touch BENCHMARKS.md")
    args = parser.parse_args()

    from legplan.dyn.costs import CostWeights
    from legplan.dyn.problem import build_problem
    from legplan.dyn.replan import MeasuredState, Previous, ReplanParams, ReplanTask, replan
    from legplan.dyn.rest_gait import remaining_gait
    from legplan.dyn.shifted_init import ShiftedInit
    from legplan.dyn.settings import PAPER
    from legplan.solve.auglag import _AugmentedRows, row_tolerances
    from legplan.solve.hinged import solve_hinged_lm
    from legplan.solve.problem import Problem

    load_start = load_average()
    model, terrain, task, planned = pallet_plan()
    previous = Previous.from_plan(planned)
    replan(previous, MeasuredState.from_samples(planned.samples, 0.05), model, terrain, PAPER)  # imports, caches
    settings = ReplanParams()
    solver = replace(PAPER.projection_solver, max_iterations=settings.max_iterations,
                     scaled_tolerance=settings.scaled_tolerance)
    stage = replace(PAPER, optimize_phases=False, costs=CostWeights())

    def one(state: MeasuredState, kind: str) -> dict:
        gait_rest, airborne = remaining_gait(previous.form.gait, state.t)
        rest = ReplanTask(previous, state, gait_rest, airborne)
        cpu = time.process_time()
        problem = build_problem(rest, model, terrain, stage, ShiftedInit(previous, state.t))
        build = time.process_time() - cpu
        cpu = time.process_time()
        kept = Problem(list(problem.variables))  # as `solve_augmented_lagrangian` poses it (no costs)
        rows = [kept.add_residual(_AugmentedRows(k)) for k in problem.constraints]
        theta = kept.layout.initial()
        widen = [t / solver.violation_tolerance for t in row_tolerances(problem.constraints, solver)]
        scale = min(float((k.scale * f).min()) for k, f in zip(problem.constraints, widen) if k.block.size)
        inner = replace(solver.inner, max_iterations=min(solver.inner.max_iterations, solver.max_iterations),
                        tolerance=solver.violation_tolerance * scale)
        row_tolerance = (solver.violation_tolerance * np.concatenate(
            [(r.constraint.scale * f)[r.pick] for r, f in zip(rows, widen)]) if solver.exact_rows else None)
        setup = time.process_time() - cpu
        solves = []
        for _ in range(1 + args.repeats):
            cpu = time.process_time()
            out = solve_hinged_lm(kept, inner, theta0=theta.copy(), row_tolerance=row_tolerance)
            solves.append(time.process_time() - cpu)
        cpu = time.process_time()
        _, J = kept.nonzero_jacobian(theta)
        jacobian = time.process_time() - cpu
        cpu = time.process_time()
        kept.residual(theta)
        residual = time.process_time() - cpu
        return {"t": state.t, "kind": kind, "rest": float(gait_rest.duration), "rows": int(J.shape[0]),
                "nnz": int(J.nnz), "iterations": int(out.iterations), "status": out.status.name,
                "build": build, "setup": setup, "first_solve": solves[0], "kept_solve": min(solves[1:]),
                "jacobian": jacobian, "residual": residual}

    rows = []
    for t in np.linspace(0.3, task.duration - 0.5, 6):
        state = MeasuredState.from_samples(planned.samples, t)
        pushed = MeasuredState(state.t, state.base_pos, state.base_euler, state.base_vel + [0, PUSH_VELOCITY, 0],
                               state.base_ang_vel, state.feet_pos)
        rows += [one(state, "unperturbed"), one(pushed, "pushed")]
    for t in np.linspace(0.37, 5.03, 12):
        rows.append(one(MeasuredState.from_samples(planned.samples, t), "distinct"))
    for r in rows:
        print(f"t = {r['t']:.2f} s {r['kind']}: build {r['build'] * 1e3:.0f} ms, LM new {r['first_solve'] * 1e3:.0f} ms, "
              f"kept {r['kept_solve'] * 1e3:.0f} ms, {r['iterations']} iterations {r['status']}", flush=True)
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
              "load_start": load_start, "load_end": load_average(), "task": TASK, "push_velocity": PUSH_VELOCITY,
              "repeats": args.repeats, "rows": rows, "summary": summary(rows)}
    path = write_result(args.result, result)
    print(f"wrote {path}")
    if not args.no_append:
        update_benchmarks(args.result, markdown(result))


def summary(rows: list[dict]) -> dict:
    """Medians per set: the bench's 12 replans ("bench") and the 12 distinct ones ("distinct")."""
    out = {}
    for name, kinds in (("bench", ("unperturbed", "pushed")), ("distinct", ("distinct",))):
        part = [r for r in rows if r["kind"] in kinds]
        fresh = [r["build"] + r["setup"] + r["first_solve"] for r in part]
        out[name] = {"build": float(np.median([r["build"] for r in part])),
                     "first_solve": float(np.median([r["first_solve"] for r in part])),
                     "fresh": float(np.median(fresh)),
                     "kept_solve": float(np.median([r["kept_solve"] for r in part])),
                     "kept_share": float(np.median([r["kept_solve"] / f for r, f in zip(part, fresh)])),
                     "iterations": float(np.median([r["iterations"] for r in part])),
                     "converged": float(np.mean([r["status"] == "CONVERGED" for r in part]))}
    return out


def markdown(r: dict) -> str:
    s = r["summary"]
    lines = "\n".join(
        f"| {name} | {x['build'] * 1e3:.0f} | {x['first_solve'] * 1e3:.0f} | {x['fresh'] * 1e3:.0f} | "
        f"{x['kept_solve'] * 1e3:.0f} | {x['kept_share']:.2f} | {x['iterations']:.0f} | {x['converged'] * 100:.0f} % |"
        for name, x in s.items())
    by_length = sorted((x for x in r["rows"] if x["kind"] != "pushed"), key=lambda x: x["rest"])
    lengths = ", ".join(f"{x['rest']:.1f} s: {x['jacobian'] * 1e3:.0f}/{x['residual'] * 1e3:.0f}" for x in by_length[::3])
    return f"""## replan_floor — what a persistent replan problem could save (`bench/replan_floor.py`, {r['date']}, {r['machine']}, code {r['code']}; load average {r['load_start']:.1f} at start, {r['load_end']:.1f} at end: shared machine, timings noisy)

`bench/replan.py`'s plan and replans ("bench": 6 instants, unperturbed and pushed, two replans per
instant sharing a problem structure) and 12 unperturbed replans at instants that share none
("distinct", the closed loop's case). CPU ms (process time, one thread), medians: building the
problem; the replan's hinged LM on a new solver problem; both (with the solver problem's setup):
a fresh replan's build and solve; the same LM again on the kept solver problem, every cache,
pattern and CHOLMOD analysis reused (the floor of a replan problem that persists, at the rest's own
length), and its share of the fresh replan.

| replans | build | LM, new problem | fresh | LM, kept problem | kept / fresh | iterations | converged |
|---|---|---|---|---|---|---|---|
{lines}

One Jacobian / one residual on the kept problem (ms) against the rest's length: {lengths}. A
problem posed on the whole plan's time axis pays the longest rest's evaluations at every replan.
"""


if __name__ == "__main__":
    main()
