"""A warm replan's work per problem at a structure seen for the first time (the closed loop's case), in
two source trees side by side (issue 39: a warm replan of the 16-footstep pallet plan).

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan_structure.py --before /path/to/tree [--after .]
        [--rounds 3] [--result-name replan_structure]

* The plan and the states: `bench/replan_instructions.py`'s (`bench/replan.py`'s plan planned once by
  the `--before` tree and handed to both trees; its 6 instants, unperturbed and pushed).
* Per state, with every structure cache of the process emptied first (the `functools` caches of
  `legplan`: sampling matrices, sampled-Jacobian and row-picker patterns; CHOLMOD's analyses): the CPU
  of building the replan's problem (`replan` up to its solve), of the first Jacobian of the augmented
  Lagrangian's problem (`Problem.nonzero_jacobian`: every pattern, assembly and nonzero set made) and
  of a second one at the same point (only values); then the whole replan again with the caches
  emptied (`ReplanResult.cpu_seconds`). In the closed loop no two replans share a structure (the
  rest's phases, knots and sample times move with t), so this is what every replan there pays;
  `bench/replan.py`'s pairs of states share one, which its second replan finds in the caches.
* Rounds of one child per tree, the order alternating; per child the median over the 12 states of
  each part, then the median over the rounds, with the load average at the start and the end.

Writes bench/results/<result-name>.json; the BENCHMARKS.md section that cites it is written by hand.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import datetime  # noqa: E402
import pickle  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from common import load_average, machine, write_result  # noqa: E402

PARTS = ("build", "first_jacobian", "second_jacobian", "replan")


def _empty_caches() -> None:
    """Every `functools` cache of the loaded `legplan` modules and CHOLMOD's analyses: the process as a
    replan of a new structure finds it."""
    for module in list(sys.modules.values()):
        if module is None or not getattr(module, "__name__", "").startswith("legplan"):
            continue
        for value in list(vars(module).values()):
            if hasattr(value, "cache_clear") and hasattr(value, "cache_info"):
                value.cache_clear()
    from legplan.solve import linsolve

    linsolve.ANALYSES._entries.clear()


def child(tree: Path, plan: Path, out: Path) -> None:
    """The parts of every state's replan (module docstring), pickled to `out`."""
    sys.path.insert(0, str(Path(__file__).parent))
    from replan_instructions import setup

    robot, model, terrain_map, terrain, previous, states = setup(tree, plan)
    import legplan.dyn.replan as replan_module
    from legplan.dyn.replan import replan
    from legplan.dyn.settings import PAPER
    from legplan.solve.auglag import _AugmentedRows
    from legplan.solve.problem import Problem

    class Built(Exception):
        pass

    solve = replan_module.solve_augmented_lagrangian
    captured = {}

    def stop(variables, costs, constraints, params, deadline=None):
        captured["problem"] = (variables, costs, constraints)
        raise Built

    rows = []
    for state in states:
        _empty_caches()
        replan_module.solve_augmented_lagrangian = stop
        start = time.process_time()
        try:
            replan(previous, state, model, terrain, PAPER)
        except Built:
            pass
        build = time.process_time() - start
        replan_module.solve_augmented_lagrangian = solve
        variables, costs, constraints = captured["problem"]
        problem = Problem(list(variables))
        for term in costs:
            problem.add_residual(term.block, np.sqrt(term.weight))
        for k in constraints:
            problem.add_residual(_AugmentedRows(k))
        theta = problem.layout.initial()
        start = time.process_time()
        problem.nonzero_jacobian(theta)
        first = time.process_time() - start
        start = time.process_time()
        problem.nonzero_jacobian(theta)
        second = time.process_time() - start
        _empty_caches()
        whole = replan(previous, state, model, terrain, PAPER)
        rows.append({"t": float(state.t), "build": build, "first_jacobian": first, "second_jacobian": second,
                     "replan": whole.cpu_seconds, "iterations": whole.iterations, "success": bool(whole.success)})
    out.write_bytes(pickle.dumps(rows))


def main() -> None:
    from replan_instructions import two_tree_parser

    args = two_tree_parser(__doc__, "replan_structure").parse_args()
    if args.child is not None:
        child(args.child, args.plan, args.out)
        return
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "load_start": load_average(),
              "trees": {k: str(v) for k, v in trees.items()}, "rounds": []}
    instructions = Path(__file__).with_name("replan_instructions.py")
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        plan = tmp / "plan.pkl"
        subprocess.run([sys.executable, str(instructions), "--child", str(trees["before"]), "--make-plan", "--out",
                        str(plan)], env=dict(os.environ, PYTHONPATH=str(trees["before"])), check=True)
        for k in range(args.rounds):
            order = ("before", "after") if k % 2 == 0 else ("after", "before")
            row = {"order": list(order), "load": load_average()}
            for label in order:
                out = tmp / "rows.pkl"
                subprocess.run([sys.executable, __file__, "--child", str(trees[label]), "--plan", str(plan),
                                "--out", str(out)], env=dict(os.environ, PYTHONPATH=str(trees[label])), check=True)
                rows = pickle.loads(out.read_bytes())
                row[label] = {part: float(np.median([r[part] for r in rows])) for part in PARTS}
                row[label]["p95_replan"] = float(np.percentile([r["replan"] for r in rows], 95))
                row[label]["iterations"] = [r["iterations"] for r in rows]
                row[label]["converged"] = sum(r["success"] for r in rows)
                print(f"round {k} {label}: " + ", ".join(f"{p} {row[label][p] * 1e3:.1f} ms" for p in PARTS)
                      + f", p95 replan {row[label]['p95_replan'] * 1e3:.0f} ms", flush=True)
            result["rounds"].append(row)
    for label in trees:
        result[label] = {part: float(np.median([r[label][part] for r in result["rounds"]]))
                         for part in (*PARTS, "p95_replan")}
    result["load_end"] = load_average()
    print(f"wrote {write_result(args.result_name, result)}")


if __name__ == "__main__":
    main()
