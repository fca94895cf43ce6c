"""Where a warm replan's CPU goes (issue 39 item 3): `bench/replan.py`'s 12 replans, each split into
building the problem, the solver's first Jacobian (its caches, patterns and CHOLMOD analysis made),
the later Jacobians, the residuals at trial points, the curvature probes (geodesic acceleration),
CHOLMOD (analysis, factorizations, rank updates, solves), the hinge model and the sampling of the
result, by timers around those functions (process time, one thread).

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan_profile.py [--repeats 2] [--result replan_profile]

Runs on the `legplan` it imports (PYTHONPATH), so two source trees compare side by side. Writes
bench/results/<NAME>.json; the BENCHMARKS.md section that cites it is written by hand.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import collections  # noqa: E402
import datetime  # noqa: E402
import functools  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402

from common import load_average, machine, write_result  # noqa: E402
from replan import PUSH_VELOCITY, pallet_plan  # noqa: E402

SPENT: dict[str, float] = collections.defaultdict(float)
CALLS: collections.Counter = collections.Counter()
OPEN: collections.Counter = collections.Counter()  # timers of a label running (a call inside another counts once)


def timed(owner, name: str, label: str | None = None) -> None:
    """Add the process time of every call of owner.name to SPENT[label] (not again within a call of the
    same label: CHOLMOD's refactor_rows may refactorize)."""
    original = getattr(owner, name)
    label = label or name

    @functools.wraps(original)
    def wrapper(*args, **kwargs):
        if OPEN[label]:
            return original(*args, **kwargs)
        OPEN[label] += 1
        start = time.process_time()
        try:
            return original(*args, **kwargs)
        finally:
            OPEN[label] -= 1
            SPENT[label] += time.process_time() - start
            CALLS[label] += 1

    setattr(owner, name, wrapper)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=2, help="passes over the 12 replans")
    parser.add_argument("--result", default="replan_profile")
    args = parser.parse_args()

    import legplan
    import legplan.dyn.replan as replan_module
    import legplan.solve.auglag as auglag
    import legplan.solve.hinged as hinged
    import legplan.solve.linsolve as linsolve
    import legplan.solve.problem as problem
    from legplan.dyn.replan import MeasuredState, replan
    from legplan.dyn.settings import PAPER

    load_start = load_average()
    model, terrain, task, planned = pallet_plan()
    replan(planned, MeasuredState.from_samples(planned.samples, 0.05), model, terrain, PAPER)  # imports, caches

    jacobian = problem.Problem.nonzero_jacobian

    def nonzero_jacobian(self, theta):  # the first of a problem apart from the later ones
        label = "later Jacobians" if getattr(self, "_profiled", False) else "first Jacobian"
        self._profiled = True
        start = time.process_time()
        try:
            return jacobian(self, theta)
        finally:
            SPENT[label] += time.process_time() - start
            CALLS[label] += 1

    problem.Problem.nonzero_jacobian = nonzero_jacobian
    timed(replan_module, "build_problem", "build problem")
    timed(replan_module, "sample_solution", "sample the result")
    timed(problem.Problem, "residual", "residuals (trial points)")
    timed(problem.Problem, "residual_rows", "curvature probes")
    for name in ("_analyze", "refactor", "refactor_rows", "set_jacobian", "solve"):
        timed(linsolve.CholmodSolver, name, "CHOLMOD")
    timed(hinged._HingeModel, "__init__", "hinge model")
    timed(auglag, "evaluate_costs", "costs")

    states = []
    for t in np.linspace(0.3, task.duration - 0.5, 6):
        state = MeasuredState.from_samples(planned.samples, t)
        states += [state, MeasuredState(state.t, state.base_pos, state.base_euler,
                                        state.base_vel + [0, PUSH_VELOCITY, 0], state.base_ang_vel, state.feet_pos)]
    cpu, iterations = [], []
    for _ in range(args.repeats):
        for state in states:
            out = replan(planned, state, model, terrain, PAPER)
            cpu.append(out.cpu_seconds)
            iterations.append(out.iterations)
    count = len(cpu)
    parts = {k: {"ms_per_replan": SPENT[k] / count * 1e3, "calls_per_replan": CALLS[k] / count} for k in SPENT}
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "legplan": str(legplan.__file__),
              "load_start": load_start, "load_end": load_average(), "replans": count,
              "median_cpu": float(np.median(cpu)), "p95_cpu": float(np.percentile(cpu, 95)), "mean_cpu": float(np.mean(cpu)),
              "median_iterations": float(np.median(iterations)), "parts": parts}
    for k, v in sorted(parts.items(), key=lambda kv: -kv[1]["ms_per_replan"]):
        print(f"{k:26s} {v['ms_per_replan']:7.1f} ms per replan ({v['calls_per_replan']:.2f} calls)")
    rest = result["mean_cpu"] * 1e3 - sum(v["ms_per_replan"] for v in parts.values())
    result["other_ms_per_replan"] = rest  # the augmented Lagrangian's and LM's own work: steps, products, tests
    print(f"{'other':26s} {rest:7.1f} ms per replan (mean {result['mean_cpu'] * 1e3:.0f} ms)")
    print(f"wrote {write_result(args.result, result)}: median {result['median_cpu'] * 1e3:.0f} ms")


if __name__ == "__main__":
    main()
