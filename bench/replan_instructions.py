"""Instructions of `bench/replan.py`'s warm replans in two source trees, side by side (issue 39: a warm
replan of the 16-footstep pallet plan).

    OMP_NUM_THREADS=1 .venv/bin/python bench/replan_instructions.py --before /path/to/tree [--after .]
        [--rounds 3] [--result-name replan_instructions]

* The plan: `bench/replan.py`'s (`pallet_plan`: the Single Pallet walk, 16 footsteps, the paper's
  costs), planned once by the `--before` tree and handed to both trees (`Previous` and its samples,
  pickled), so that both replan the very same plan from the very same states.
* Replans: `bench/replan.py`'s 12 (6 instants, unperturbed and pushed +0.1 m/s), each `replan` with
  the paper's settings, after one replan at t = 0.05 s that pays the process's one-time work
  (imports, caches), as a closed loop's later replans find it.
* Instructions: the child runs under `valgrind --tool=callgrind --instr-atstart=no`; it builds the
  model and the map and loads the plan uninstrumented, then the parent switches the instrumentation
  on (`callgrind_control -i on`) for the 12 replans alone, run without their CPU budget
  (`ReplanParams.cpu_budget` None: under valgrind a replan is some 50 times slower and would stop at
  its budget). Callgrind's "Collected" count is repeatable under any load.
* CPU: `--rounds` rounds of one child per tree without valgrind, the trees' order alternating; per
  child the median and p95 of the 12 replans' CPU seconds (`ReplanResult.cpu_seconds`), then the
  median over the rounds, with the load average at the start and the end.
* Answers: per replan the iterations, success and scaled violation of each tree, and the largest
  difference of any node value between the trees' replans; with `--check` also the independent
  check of every replanned plan (`legplan.validate.trajectory.check_trajectory` on its samples, as
  `legplan dyn replan` runs it), one more child per tree.

Writes bench/results/<result-name>.json; the BENCHMARKS.md section that cites it is written by hand.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import pickle  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from common import ROOT, callgrind_instructions, load_average, machine, write_result  # noqa: E402


def make_plan(tree: Path, out: Path) -> None:
    """In a process whose sys.path starts with `tree`: `bench/replan.py`'s plan, pickled."""
    sys.path.insert(0, str(tree / "bench"))
    from replan import pallet_plan

    from legplan.dyn.replan import Previous

    _, _, task, planned = pallet_plan()
    out.write_bytes(pickle.dumps({"previous": Previous.from_plan(planned), "samples": planned.samples,
                                  "duration": task.duration, "status": planned.status.name,
                                  "iterations": int(planned.solve.iterations)}))


def setup(tree: Path, plan: Path):
    """In a process whose sys.path starts with `tree`: the robot, its centroidal model, the map and its
    terrain model, the pickled plan (`Previous`, its samples) and the 12 states of `bench/replan.py`
    (6 instants, unperturbed and pushed), after one replan at t = 0.05 s (the one-time work)."""
    sys.path.insert(0, str(tree / "bench"))
    from replan import PUSH_VELOCITY

    from legplan.dyn.replan import MeasuredState, replan
    from legplan.dyn.settings import PAPER
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain.spec import build_map

    robot = load_robot("anymal")
    model = centroidal_model(robot, PAPER, "paper")
    terrain_map = build_map(tree / "maps" / "single_pallet.yaml")
    terrain = TerrainModel(terrain_map)
    saved = pickle.loads(plan.read_bytes())
    previous, samples = saved["previous"], saved["samples"]
    replan(previous, MeasuredState.from_samples(samples, 0.05), model, terrain, PAPER)  # one-time work
    states = []
    for t in np.linspace(0.3, saved["duration"] - 0.5, 6):
        state = MeasuredState.from_samples(samples, t)
        states += [state, MeasuredState(state.t, state.base_pos, state.base_euler,
                                        state.base_vel + [0, PUSH_VELOCITY, 0], state.base_ang_vel, state.feet_pos)]
    return robot, model, terrain_map, terrain, previous, states


def child(tree: Path, plan: Path, out: Path, handshake: bool, check: bool = False) -> None:
    """Replan the pickled plan 12 times (module docstring); with `handshake` say READY and wait for a
    line before the replans and after them."""
    robot, model, terrain_map, terrain, previous, states = setup(tree, plan)
    from legplan.dyn.replan import ReplanParams, replan
    from legplan.dyn.settings import PAPER

    # under callgrind a replan runs some 50 times slower: without its CPU budget, so that it does the
    # work it does natively (with it, replans stop at the budget after an iteration or none)
    settings = ReplanParams(cpu_budget=None) if handshake else ReplanParams()
    if handshake:
        print("READY", flush=True)
        sys.stdin.readline()
    outs = [replan(previous, state, model, terrain, PAPER, settings=settings) for state in states]
    if handshake:
        print("DONE", flush=True)
        sys.stdin.readline()
    rows = [{"t": float(o.state.t), "cpu": o.cpu_seconds, "iterations": o.iterations, "success": bool(o.success),
             "scaled_violation": float(o.scaled_violation),
             "values": {k: np.array(v) for k, v in o.plan.solve.values.items()}} for o in outs]
    if check:
        from legplan.validate.trajectory import check_trajectory

        for row, o in zip(rows, outs):
            c = check_trajectory(o.plan.samples, model, terrain_map, robot, node_times=o.plan.problem.form.knots)
            row["check"] = {"ok": bool(c.ok), "failed": sorted(k for k, ok in c.passed.items() if not ok)}
    out.write_bytes(pickle.dumps(rows))


def _command(tree: Path, plan: Path, out: Path, handshake: bool, check: bool = False) -> list[str]:
    return [sys.executable, __file__, "--child", str(tree), "--plan", str(plan), "--out", str(out)] + (
        ["--handshake"] if handshake else []) + (["--check"] if check else [])


def instructions(tree: Path, plan: Path, tmp: Path) -> tuple[int, list[dict]]:
    out = tmp / "replans.pkl"
    count = callgrind_instructions(_command(tree, plan, out, True), dict(os.environ, PYTHONPATH=str(tree)), tmp,
                                   str(tree))
    return count, pickle.loads(out.read_bytes())


def cpu(tree: Path, plan: Path, tmp: Path, check: bool = False) -> list[dict]:
    out = tmp / "replans.pkl"
    subprocess.run(_command(tree, plan, out, False, check), env=dict(os.environ, PYTHONPATH=str(tree)), check=True)
    return pickle.loads(out.read_bytes())


def summary(rows: list[dict]) -> dict:
    seconds = np.array([r["cpu"] for r in rows])
    return {"median": float(np.median(seconds)), "p95": float(np.percentile(seconds, 95)),
            "iterations": [r["iterations"] for r in rows], "converged": float(np.mean([r["success"] for r in rows])),
            "scaled_violation": [r["scaled_violation"] for r in rows]}


def largest_difference(a: list[dict], b: list[dict]) -> float:
    """The largest difference of any node value between the trees' replans of the same state; inf
    where a replan's layout differs between the trees (other knots: no entry-by-entry comparison)."""
    worst = 0.0
    for x, y in zip(a, b, strict=True):
        for name, value in x["values"].items():
            if np.shape(value) != np.shape(y["values"][name]):
                return float("inf")
            worst = max(worst, float(np.max(np.abs(value - y["values"][name]), initial=0.0)))
    return worst


def two_tree_parser(doc: str, result_name: str) -> argparse.ArgumentParser:
    """The options of a bench that runs two source trees side by side on this plan: the trees, the
    rounds, the result's name, and the hidden ones of its children."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--before", type=Path)
    parser.add_argument("--after", type=Path, default=ROOT)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--result-name", default=result_name)
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--plan", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    return parser


def main() -> None:
    parser = two_tree_parser(__doc__, "replan_instructions")
    parser.add_argument("--no-callgrind", action="store_true")
    parser.add_argument("--check", action="store_true", help="the independent check of every replan (one more child per tree)")
    parser.add_argument("--make-plan", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--handshake", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child is not None:
        if args.make_plan:
            make_plan(args.child, args.out)
        else:
            child(args.child, args.plan, args.out, args.handshake, args.check)
        return
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    load_start = load_average()
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "load_start": load_start,
              "trees": {k: str(v) for k, v in trees.items()}, "rounds": []}
    with tempfile.TemporaryDirectory() as name:
        tmp = Path(name)
        plan = tmp / "plan.pkl"
        subprocess.run([sys.executable, __file__, "--child", str(trees["before"]), "--make-plan", "--out", str(plan)],
                       env=dict(os.environ, PYTHONPATH=str(trees["before"])), check=True)
        saved = pickle.loads(plan.read_bytes())
        result["plan"] = {"status": saved["status"], "iterations": saved["iterations"]}
        answers = {}
        if not args.no_callgrind:
            result["instructions"] = {}
            for label, tree in trees.items():
                count, rows = instructions(tree, plan, tmp)
                result["instructions"][label] = count
                answers[label] = rows
                print(f"{label}: {count / 1e9:.3f} e9 instructions", flush=True)
            result["instruction_ratio"] = result["instructions"]["after"] / result["instructions"]["before"]
        for k in range(args.rounds):
            order = ("before", "after") if k % 2 == 0 else ("after", "before")
            row = {"order": list(order), "load": load_average()}
            for label in order:
                rows = cpu(trees[label], plan, tmp)
                answers.setdefault(label, rows)
                row[label] = summary(rows)
                print(f"round {k} {label}: median {row[label]['median'] * 1e3:.0f} ms, "
                      f"p95 {row[label]['p95'] * 1e3:.0f} ms", flush=True)
            result["rounds"].append(row)
        if args.check:
            result["checks"] = {}
            for label, tree in trees.items():
                rows = cpu(tree, plan, tmp, check=True)
                answers.setdefault(label, rows)
                result["checks"][label] = [r["check"] for r in rows]
                print(f"{label}: independent check passed on {sum(c['ok'] for c in result['checks'][label])} "
                      f"of {len(rows)} replans", flush=True)
    result["answers"] = {label: [{k: v for k, v in r.items() if k != "values"} for r in rows]
                         for label, rows in answers.items()}
    result["largest_difference"] = largest_difference(answers["before"], answers["after"])
    for label in trees:
        if result["rounds"]:
            result[label] = {"median": float(np.median([r[label]["median"] for r in result["rounds"]])),
                             "p95": float(np.median([r[label]["p95"] for r in result["rounds"]]))}
    result["load_end"] = load_average()
    print(f"wrote {write_result(args.result_name, result)}; largest difference {result['largest_difference']:.1e}")


if __name__ == "__main__":
    main()
