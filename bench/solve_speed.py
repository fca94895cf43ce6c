"""Side-by-side CPU of the centroidal solve in two source trees, alternated in one session (issues 34,
38, 39: the cost of an LM iteration and of building the problem).

    OMP_NUM_THREADS=1 .venv/bin/python bench/solve_speed.py --before /path/to/tree [--after .] [--rounds 3]
                                       [--cases flat_trot,...] [--replans 6] [--model scalar|planner]
                                       [--no-command] [--section solve_speed] [--no-append]

* Cases: bench/dyn.py's five TOWR cases, planned by `legplan.dyn.planner.plan` with `DynParams()`
  from the heuristic, CPU seconds (process time) of the solve (every `solve_augmented_lagrangian`)
  and of the whole `plan` call, as bench/dyn.py measures them (its `plan_once`, from each tree's own
  bench/dyn.py), on TOWR's scalar model (`--model scalar`, `robot.centroidal`, as bench/dyn.py) or
  on the planner's own (`--model planner`: `legplan.dyn.tasks.centroidal_model`, the joint-torque
  rows included, as `legplan dyn plan` solves); and bench/replan.py's warm replans (the 16-footstep single pallet walk with the
  paper's costs, replanned from its own state at `--replans` instants, unperturbed and pushed), CPU
  of `replan` (build and solve).
* The whole `legplan dyn plan` command on the flat trot: CPU seconds of the process (issue 38).
* Every round runs one child process per tree (the order alternates), one thread each, so both
  trees see the same machine load; the medians over rounds are reported with the load average.
* The answers of both trees are compared entry by entry (every variable of every plan and replan):
  the largest absolute difference per case is reported next to the solver's own violation
  tolerance (bench/dyn.py's `VIOLATION_TOL`), and the iteration counts side by side.

Writes bench/results/solve_speed.json and replaces the `solve_speed` section of BENCHMARKS.md.
"""

from __future__ import annotations

import os

for _name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_name, "1")

import argparse  # noqa: E402
import datetime  # noqa: E402
import json  # noqa: E402
import pickle  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402

TOWR_CASES = ("flat_trot", "flat_walk", "single_walk", "single_trot", "double_walk")
REPLAN_TASK = ((-1.0, 0.0, 0.0), (0.6, 0.0, 0.0))
PUSH_VELOCITY = 0.1  # m/s, as bench/replan.py
MODELS = {"scalar": "TOWR's scalar model (`robot.centroidal`), as bench/dyn.py",
          "planner": "the planner's model (`centroidal_model`: the URDF's joint torque limits as rows)"}


def child(tree: Path, cases: list[str], replans: int, out: Path, model_kind: str = "scalar") -> None:
    """Run in a child process whose sys.path starts with `tree`: plan the cases and the replans,
    pickle CPU times, iterations and answers to `out`."""
    import time

    sys.path.insert(0, str(tree / "bench"))
    import dyn as bench_dyn  # the tree's own bench/dyn.py (its cases and `plan_once`)
    from legplan.dyn.problem import DynParams, DynTask
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain import build_map

    assert Path(bench_dyn.__file__).resolve().is_relative_to(tree.resolve()), bench_dyn.__file__
    robot = load_robot("anymal")
    if model_kind == "planner":
        from legplan.dyn.tasks import centroidal_model

        case_model = centroidal_model(robot)
    else:
        case_model = robot.centroidal
    result = {"cases": {}, "replans": []}
    terrains = {}
    for key in cases:
        case = next(c for c in bench_dyn.CASES if c["key"] == key)
        if case["map"] not in terrains:
            terrains[case["map"]] = TerrainModel(build_map(tree / "maps" / f"{case['map']}.yaml"))
        res, total, solve = bench_dyn.plan_once(case, case_model, terrains[case["map"]], DynParams())
        result["cases"][key] = {"solve": solve, "total": total, "iterations": int(res.solve.iterations),
                                "violation": float(res.solve.max_violation), "status": res.status.name,
                                "values": {k: np.array(v) for k, v in res.solve.values.items()}}
    if replans:
        from legplan.dyn.planner import plan
        from legplan.dyn.replan import MeasuredState, ReplanParams, replan
        from legplan.dyn.settings import PAPER
        from legplan.dyn.tasks import centroidal_model

        model = centroidal_model(robot, PAPER, "paper")
        terrain = TerrainModel(build_map(tree / "maps" / "single_pallet.yaml"))
        task = DynTask(*REPLAN_TASK, "walk", 4, 5.5)
        planned = plan(task, model, terrain, PAPER)
        for t in np.linspace(0.3, task.duration - 0.5, replans):
            state = MeasuredState.from_samples(planned.samples, t)
            pushed = MeasuredState(state.t, state.base_pos, state.base_euler,
                                   state.base_vel + [0, PUSH_VELOCITY, 0], state.base_ang_vel, state.feet_pos)
            for kind, measured in (("unperturbed", state), ("pushed", pushed)):
                t0 = time.process_time()
                out_r = replan(planned, measured, model, terrain, PAPER, settings=ReplanParams())
                result["replans"].append({"t": float(t), "kind": kind, "cpu": time.process_time() - t0,
                                          "iterations": out_r.iterations, "success": bool(out_r.success),
                                          "values": {k: np.array(v) for k, v in out_r.plan.solve.values.items()}})
    out.write_bytes(pickle.dumps(result))


def run_tree(tree: Path, cases: list[str], replans: int, model_kind: str = "scalar", command: bool = True) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.pkl"
        env = dict(os.environ, PYTHONPATH=str(tree))
        subprocess.run([sys.executable, __file__, "--child", str(tree), "--cases", ",".join(cases),
                        "--replans", str(replans), "--model", model_kind, "--out", str(out)], env=env, check=True)
        result = pickle.loads(out.read_bytes())
        result["command_cpu"] = command_cpu(tree, Path(tmp), env) if command else float("nan")
        return result


def command_cpu(tree: Path, tmp: Path, env: dict) -> float:
    """CPU seconds (user + system) of the whole `legplan dyn plan` process on the flat trot (issue 38),
    the map built beforehand (not counted)."""
    import resource

    legplan = [sys.executable, "-m", "legplan"]
    subprocess.run(legplan + ["map", "build", str(tree / "maps" / "flat.yaml"), "-o", str(tmp / "flat.h5"), "-q"],
                   env=env, check=True)
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    subprocess.run(legplan + ["dyn", "plan", str(tmp / "flat.h5"), "--gait", "trot", "--strides", "4", "--duration",
                              "2.4", "--start", "0", "0", "0", "--goal", "1.0", "0", "0", "-o", str(tmp / "traj.h5"),
                              "-q"], env=env, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def largest_difference(a: dict, b: dict) -> float:
    """The largest absolute difference over every entry of two answers' variables (inf if their
    shapes differ)."""
    worst = 0.0
    for name in a:
        if name not in b or np.shape(a[name]) != np.shape(b[name]):
            return float("inf")
        if np.size(a[name]):
            worst = max(worst, float(np.max(np.abs(np.asarray(a[name]) - np.asarray(b[name])))))
    return worst


def summarize(rounds: list[dict[str, dict]], labels: tuple[str, str]) -> dict:
    before, after = labels
    cases = {}
    for key in rounds[0][before]["cases"]:
        row = {}
        for label in labels:
            runs = [r[label]["cases"][key] for r in rounds]
            row[label] = {"solve_s": float(np.median([x["solve"] for x in runs])),
                          "total_s": float(np.median([x["total"] for x in runs])),
                          "runs_solve_s": [x["solve"] for x in runs], "iterations": runs[-1]["iterations"],
                          "violation": runs[-1]["violation"], "status": runs[-1]["status"]}
        row["largest_difference"] = largest_difference(rounds[-1][before]["cases"][key]["values"],
                                                       rounds[-1][after]["cases"][key]["values"])
        row["speedup"] = row[before]["solve_s"] / row[after]["solve_s"]
        cases[key] = row
    command = {label: float(np.median([r[label]["command_cpu"] for r in rounds])) for label in labels}
    replans = {}
    if rounds[0][before]["replans"]:
        for label in labels:
            per_round = [[x["cpu"] for x in r[label]["replans"]] for r in rounds]
            replans[label] = {"median_s": float(np.median([np.median(c) for c in per_round])),
                              "p95_s": float(np.median([np.percentile(c, 95) for c in per_round])),
                              "median_iterations": float(np.median([x["iterations"] for x in rounds[-1][label]["replans"]])),
                              "converged": float(np.mean([x["success"] for x in rounds[-1][label]["replans"]]))}
        replans["largest_difference"] = max(largest_difference(x["values"], y["values"]) for x, y in
                                            zip(rounds[-1][before]["replans"], rounds[-1][after]["replans"]))
        replans["same_iterations"] = all(x["iterations"] == y["iterations"] for x, y in
                                         zip(rounds[-1][before]["replans"], rounds[-1][after]["replans"]))
    return {"cases": cases, "replans": replans, "command_cpu": command}


def markdown(r: dict) -> str:
    before, after = r["labels"]
    lines = [f"## {r.get('section', 'solve_speed')} — the centroidal solve, two trees side by side (`bench/solve_speed.py`, {r['date']}, "
             f"{r['machine']}, load average {r['load_start']:.1f} at start, {r['load_end']:.1f} at end: shared machine, "
             "timings noisy)", "",
             f"`{before}` = {r['trees'][before]}, `{after}` = {r['trees'][after]}; {r['rounds']} rounds, each one child "
             "process per tree in alternating order, one thread; medians over rounds of CPU seconds (process time). "
             f"Solve = every `solve_augmented_lagrangian` of `plan` (`DynParams()`, heuristic start) on "
             f"{MODELS[r.get('model', 'scalar')]}; "
             "largest difference = the largest absolute difference of any variable entry between the two trees' answers "
             "(m, rad, N; the solver's violation tolerance is 1e-3).", "",
             f"| case | solve {before} (s) | solve {after} (s) | speed-up | whole plan {before} / {after} (s) | "
             f"iterations {before} / {after} | largest difference | TOWR solve (s) | {after} / TOWR |",
             "|---|---|---|---|---|---|---|---|---|"]
    towr = {"flat_trot": 0.53, "flat_walk": 0.97, "single_walk": 1.27, "single_trot": 4.55, "double_walk": 3.00}
    ratios = []
    for key, row in r["cases"].items():
        ratio = row[after]["solve_s"] / towr[key] if key in towr else float("nan")
        ratios.append(ratio)
        lines.append(f"| {key} | {row[before]['solve_s']:.2f} | {row[after]['solve_s']:.2f} | {row['speedup']:.2f}× | "
                     f"{row[before]['total_s']:.2f} / {row[after]['total_s']:.2f} | {row[before]['iterations']} / "
                     f"{row[after]['iterations']} | {row['largest_difference']:.1e} | {towr.get(key, float('nan')):.2f} | "
                     f"{ratio:.2f}× |")
    lines += ["", f"Median {after}/TOWR over the cases: {np.median(ratios):.2f}× (issue 34's target ≤ 0.5×; TOWR's figures "
              "are bench/dyn.py's reference column, measured on this machine on an idle day)."]
    if np.isfinite(r["command_cpu"][after]):
        lines += ["", f"Whole `legplan dyn plan` process on the flat trot (CPU, start-up included; issue 38's target ≤ "
                  f"1.0 s): {before} {r['command_cpu'][before]:.2f} s, {after} {r['command_cpu'][after]:.2f} s."]
    rp = r["replans"]
    if rp:
        lines += ["", f"Warm replans (bench/replan.py's set: {r['replans_count']} instants × unperturbed/pushed, CPU of "
                  "`replan`, build included):", "",
                  "| tree | median (ms) | p95 (ms) | median iterations | converged |", "|---|---|---|---|---|"]
        for label in (before, after):
            x = rp[label]
            lines.append(f"| {label} | {x['median_s'] * 1e3:.0f} | {x['p95_s'] * 1e3:.0f} | {x['median_iterations']:.0f} | "
                         f"{x['converged'] * 100:.0f} % |")
        lines += ["", f"Largest difference between the trees' replans: {rp['largest_difference']:.1e}; same iteration "
                  f"counts: {'yes' if rp['same_iterations'] else 'no'}. Target (issue 39): median ≤ 50 ms, p95 ≤ 100 ms."]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--before", type=Path, help="source tree of the reference (e.g. an export of main)")
    parser.add_argument("--before-name", default="", help="what the reference tree is (for the table)")
    parser.add_argument("--after", type=Path, default=ROOT)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--cases", default=",".join(TOWR_CASES))
    parser.add_argument("--replans", type=int, default=6, help="replan instants (0: no replans)")
    parser.add_argument("--model", choices=tuple(MODELS), default="scalar", help="the cases' centroidal model")
    parser.add_argument("--no-command", action="store_true", help="skip the whole `dyn plan` command's CPU")
    parser.add_argument("--section", default="solve_speed", help="the BENCHMARKS.md section it replaces")
    parser.add_argument("--no-append", action="store_true")
    parser.add_argument("--result-name", default="solve_speed", help="bench/results/NAME.json")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args()
    cases = [c for c in args.cases.split(",") if c]
    if args.child is not None:
        child(args.child, cases, args.replans, args.out, args.model)
        return
    if args.before is None:
        parser.error("--before is required")
    labels = ("before", "after")
    trees = {"before": f"{args.before.resolve()}" + (f" ({args.before_name})" if args.before_name else ""),
             "after": f"{args.after.resolve()} (code {code_version()})"}
    paths = {"before": args.before.resolve(), "after": args.after.resolve()}
    load_start = load_average()
    rounds = []
    for k in range(args.rounds):
        order = labels if k % 2 == 0 else labels[::-1]
        got = {}
        for label in order:
            got[label] = run_tree(paths[label], cases, args.replans, args.model, not args.no_command)
            solves = ", ".join(f"{key} {v['solve']:.2f}" for key, v in got[label]["cases"].items())
            print(f"round {k + 1} {label}: {solves}; replans median "
                  f"{np.median([x['cpu'] for x in got[label]['replans']] or [np.nan]) * 1e3:.0f} ms; dyn plan command "
                  f"{got[label]['command_cpu']:.2f} s CPU", flush=True)
        rounds.append(got)
    summary = summarize(rounds, labels)
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
              "trees": trees, "labels": labels, "rounds": args.rounds, "model": args.model, "section": args.section,
              "replans_count": args.replans, "load_start": load_start, "load_end": load_average(), **summary}
    text = markdown(result)
    print(text)
    write_result(args.result_name, result)
    if not args.no_append:
        update_benchmarks(args.section, text)


if __name__ == "__main__":
    main()
