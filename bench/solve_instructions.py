"""Instructions and CPU of the centroidal solve in two source trees, side by side (issue 38: the solve of
the one-shot `legplan dyn plan`).

    OMP_NUM_THREADS=1 .venv/bin/python bench/solve_instructions.py --before /path/to/tree [--after .]
        [--cases flat_trot,...] [--rounds 3] [--no-callgrind] [--section solve_instructions]
        [--result-name solve_instructions] [--no-append]
    .venv/bin/python bench/solve_instructions.py --merge COUNTED... TIMED --result-name NAME --section NAME

* Cases: bench/dyn.py's TOWR cases (`TOWR_CASES`), each planned once in a fresh child process by
  `legplan.dyn.planner.plan` with `DynParams()` from the heuristic on the planner's own model
  (`legplan.dyn.tasks.centroidal_model`, the joint-torque rows included), as `legplan dyn plan`
  plans it: the process's first plan, its one-time work (patterns, analyses, caches) included.
* Instructions: the child runs under `valgrind --tool=callgrind --instr-atstart=no`; it loads the
  robot, the model and the map uninstrumented, then the parent switches the instrumentation on
  (`callgrind_control -i on`) for the `plan` call alone and off after it. The count is callgrind's
  "Collected" total: the instructions of `plan` (problem build, solve, sampling), repeatable under
  any load. Instrumentation is switched per process, so both trees' counts are of the same work.
* CPU: `--rounds` rounds of one child per tree without valgrind, the trees' order alternating, one
  thread each; CPU seconds (process time) inside `solve_augmented_lagrangian` and of the whole
  `plan` call, medians over rounds, with the load average at the start and the end (a shared
  machine's CPU seconds are noisy; the instruction counts are not).
* Answers: every variable of both trees' plans compared entry by entry (largest absolute
  difference), with the status, the LM iterations and the largest constraint violation of each.

Writes bench/results/<result-name>.json and replaces the `<section>` section of BENCHMARKS.md.
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

from common import (ROOT, callgrind_instructions, code_version, load_average, machine,  # noqa: E402
                    update_benchmarks, write_result)

TOWR_CASES = ("flat_trot", "flat_walk", "single_walk", "single_trot", "double_walk")
ALL_CASES = TOWR_CASES + ("flat_trot_2", "stairs_walk")  # bench/dyn.py's `CASES`
TOWR_PROCESS = {"flat_trot": 0.80, "flat_walk": 1.87, "single_walk": 2.58, "single_trot": 6.92, "double_walk": 3.99}
"""s: TOWR's whole process on this machine on an idle day (issue 38's reference column; not run here)."""


def child(tree: Path, key: str, out: Path, handshake: bool) -> None:
    """In a process whose sys.path starts with `tree`: build what `plan` needs, then (with
    `handshake`) say READY and wait for a line before `plan` and after it; pickle the outcome."""
    sys.path.insert(0, str(tree / "bench"))
    import dyn as bench_dyn  # the tree's own cases and `plan_once` (CPU of the solve and of `plan`)
    from legplan.dyn.problem import DynParams
    from legplan.dyn.tasks import centroidal_model
    from legplan.dyn.terrain import TerrainModel
    from legplan.robots import load_robot
    from legplan.terrain import build_map

    case = next(c for c in bench_dyn.CASES if c["key"] == key)
    robot = load_robot("anymal")
    model = centroidal_model(robot)
    terrain_map = build_map(tree / "maps" / f"{case['map']}.yaml")
    terrain = TerrainModel(terrain_map)
    if handshake:
        print("READY", flush=True)
        sys.stdin.readline()
    result, total, solve = bench_dyn.plan_once(case, model, terrain, DynParams())
    if handshake:
        print("DONE", flush=True)
        sys.stdin.readline()
        check = None
    else:  # the independent check of the answer (`legplan.validate.trajectory`), as `dyn plan` runs it
        check = bench_dyn.dense_check(result.samples, model, terrain_map, robot, result.problem.form.knots)
    out.write_bytes(pickle.dumps({"solve": solve, "total": total, "status": result.status.name, "check": check,
                                  "iterations": int(result.solve.iterations),
                                  "violation": float(result.solve.max_violation),
                                  "values": {k: np.array(v) for k, v in result.solve.values.items()}}))


def _command(tree: Path, key: str, out: Path, handshake: bool) -> list[str]:
    return [sys.executable, __file__, "--child", str(tree), "--case", key, "--out", str(out)] + (
        ["--handshake"] if handshake else [])


def instructions(tree: Path, key: str, tmp: Path) -> dict:
    """Callgrind's instruction count of the `plan` call of one case in `tree` (module docstring)."""
    out = tmp / f"{key}.pkl"
    count = callgrind_instructions(_command(tree, key, out, True), dict(os.environ, PYTHONPATH=str(tree)), tmp,
                                   f"{tree} {key}")
    result = pickle.loads(out.read_bytes())
    result["instructions"] = count
    return result


def cpu(tree: Path, key: str, tmp: Path) -> dict:
    out = tmp / f"{key}.pkl"
    subprocess.run(_command(tree, key, out, False), env=dict(os.environ, PYTHONPATH=str(tree)), check=True)
    return pickle.loads(out.read_bytes())


def largest_difference(a: dict, b: dict) -> float:
    worst = 0.0
    for name in a:
        if name not in b or np.shape(a[name]) != np.shape(b[name]):
            return float("inf")
        if np.size(a[name]):
            worst = max(worst, float(np.max(np.abs(a[name] - b[name]))))
    return worst


def markdown(r: dict) -> str:
    before, after = r["labels"]
    lines = [f"## {r['section']} — the `dyn plan` solve, instructions and CPU of two trees side by side "
             f"(`bench/solve_instructions.py`, {r['date']}, {r['machine']}, load average {r['load_start']:.1f} at start, "
             f"{r['load_end']:.1f} at end: shared machine, CPU seconds noisy, instruction counts not)", "",
             f"`{before}` = {r['trees'][before]}, `{after}` = {r['trees'][after]}. Each case planned once per child "
             "process by `plan` with `DynParams()` from the heuristic on the planner's model (`centroidal_model`, "
             "joint-torque rows included), as `legplan dyn plan` plans it, its one-time work included. Instructions: "
             "callgrind's count of the `plan` call alone (instrumentation switched on for it). CPU: medians over "
             f"{r['rounds']} alternated rounds of CPU seconds inside `solve_augmented_lagrangian` and of the whole `plan`. "
             "Largest difference: of any variable entry between the two trees' answers (m, rad, N; the solver's "
             "violation tolerance is 1e-3 in the rows' units). Independent check: `legplan.validate.trajectory."
             "check_trajectory` on the 10 ms samples (bench/dyn.py's `dense_check`), as `dyn plan` runs it.", "",
             f"| case | instructions {before} | instructions {after} | {after} / {before} | solve CPU {before} / "
             f"{after} (s) | plan CPU {before} / {after} (s) | iterations {before} / {after} | status | independent check | "
             "largest difference |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    ratios = []

    def count(side: dict) -> str:
        return f"{side['instructions'] / 1e9:.3f} e9" if "instructions" in side else "—"

    def check(side: dict) -> str:
        c = side.get("check")
        return "—" if not c else ("passed" if c.get("ok") else "failed: " + ", ".join(c.get("failed", [c.get("error", "")])))

    for key, row in r["cases"].items():
        b, a = row[before], row[after]
        ratio = a["instructions"] / b["instructions"] if "instructions" in a and "instructions" in b else float("nan")
        ratios.append(ratio)
        lines.append(f"| {key} | {count(b)} | {count(a)} | {ratio:.3f} | {b['solve_s']:.3f} / {a['solve_s']:.3f} | "
                     f"{b['total_s']:.3f} / {a['total_s']:.3f} | {b['iterations']} / {a['iterations']} | "
                     f"{b['status']} / {a['status']} | {check(b)} / {check(a)} | {row['largest_difference']:.1e} |")
    if not np.all(np.isnan(ratios)):
        lines += ["", f"Median instruction ratio {after}/{before} over the cases counted: {np.nanmedian(ratios):.3f}."]
    return "\n".join(lines)


def merged(counted: list[dict], timed: dict) -> dict:
    """Results of callgrind-only runs (`--rounds 0`, disjoint cases) with the CPU seconds, checks and
    answers of a CPU-only run (`--no-callgrind`) of the same trees: one table, in the CPU run's order."""
    out = dict(json.loads(json.dumps(timed)), callgrind=True)
    for part in counted:
        for key, row in part["cases"].items():
            for label in out["labels"]:
                out["cases"][key][label]["instructions"] = row[label]["instructions"]
                out["cases"][key][label]["instructions_run"] = {k: row[label][k] for k in ("iterations", "status")}
    out.update(load_start=min([timed["load_start"]] + [p["load_start"] for p in counted]),
               load_end=max([timed["load_end"]] + [p["load_end"] for p in counted]),
               merged_from=[p["section"] for p in counted] + [timed["section"]])
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--before", type=Path)
    parser.add_argument("--before-name", default="before")
    parser.add_argument("--after", type=Path, default=ROOT)
    parser.add_argument("--cases", default=",".join(ALL_CASES), help="CPU runs and the independent check")
    parser.add_argument("--callgrind-cases", default=",".join(TOWR_CASES))
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--no-callgrind", action="store_true")
    parser.add_argument("--section", default="solve_instructions")
    parser.add_argument("--result-name", default="solve_instructions")
    parser.add_argument("--no-append", action="store_true")
    parser.add_argument("--merge", nargs="+", metavar="NAME",
                        help="no runs: merge callgrind-only results and, last, a CPU-only result (bench/results/NAME.json) "
                             "into --result-name, --section")
    parser.add_argument("--child", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--case", help=argparse.SUPPRESS)
    parser.add_argument("--out", type=Path, help=argparse.SUPPRESS)
    parser.add_argument("--handshake", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child, args.case, args.out, args.handshake)
        return
    if args.merge:
        *counted, timed = (json.loads((ROOT / "bench" / "results" / f"{name}.json").read_text()) for name in args.merge)
        result = dict(merged(counted, timed), section=args.section)
        write_result(args.result_name, result)
        print(markdown(result))
        if not args.no_append:
            update_benchmarks(args.section, markdown(result))
        return
    if args.before is None:
        parser.error("--before is required")
    labels = ("before", "after")
    trees = {"before": args.before.resolve(), "after": args.after.resolve()}
    cases = args.cases.split(",")
    load_start = load_average()
    rows = {key: {label: {} for label in labels} for key in cases}
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        if not args.no_callgrind:
            for key in args.callgrind_cases.split(","):
                for label in labels:
                    rows[key][label].update(instructions(trees[label], key, tmp))
                    print(f"{key} {label} instructions {rows[key][label]['instructions']:.4e}", flush=True)
        runs = {key: {label: [] for label in labels} for key in cases}
        for k in range(args.rounds):
            for key in cases:
                for label in (labels if k % 2 == 0 else labels[::-1]):
                    runs[key][label].append(cpu(trees[label], key, tmp))
                    print(f"round {k} {key} {label} solve {runs[key][label][-1]['solve']:.3f}", flush=True)
    for key in cases:
        for label in labels:
            done = runs[key][label]
            last = done[-1] if done else rows[key][label]
            rows[key][label].update({"check": last.get("check"),
                                     "solve_s": float(np.median([x["solve"] for x in done])) if done else float("nan"),
                                     "total_s": float(np.median([x["total"] for x in done])) if done else float("nan"),
                                     "runs_solve_s": [x["solve"] for x in done], "iterations": last["iterations"],
                                     "status": last["status"], "violation": last["violation"]})
        values = [(runs[key][label][-1] if runs[key][label] else rows[key][label])["values"] for label in labels]
        rows[key]["largest_difference"] = largest_difference(*values)
        for label in labels:
            rows[key][label].pop("values", None)
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
              "load_start": load_start, "load_end": load_average(), "rounds": args.rounds, "labels": list(labels),
              "section": args.section, "callgrind": not args.no_callgrind,
              "trees": {"before": f"{trees['before']} ({args.before_name})", "after": f"{trees['after']} (code {code_version()})"},
              "towr_process_s": TOWR_PROCESS, "cases": rows}
    write_result(args.result_name, result)
    print(markdown(result))
    if not args.no_append:
        update_benchmarks(args.section, markdown(result))


if __name__ == "__main__":
    main()
