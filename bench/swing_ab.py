"""Step planning's whole swings, this tree against a reference tree: CPU side by side, results compared exactly.

    nice -n 5 .venv/bin/python bench/swing_ab.py --before /tmp/ref --before-code REV [--map map.h5 --steps steps.h5]
                                                 [--rounds 3] [--swings 0:102] [--instructions 9,46,64,83]
                                                 [--name swing_ab] [--no-append]

Every whole swing of the gap-crossing scenario (bench/step_plan.py's `scenario` and `merge_swings`; built
if --map/--steps are not given) is planned by one long-lived process per tree (one BLAS thread), swing by
swing in alternation (which tree goes first swaps every swing and every round), --rounds times; a swing's
CPU (`time.process_time` around `plan_step`) is the median of its rounds, and the trees' medians over the
swings are compared. A tree that plans a swing differently in two rounds stops the bench. The results are
compared exactly: control points, ‖F̃‖, success, the final degree and per degree its LM iterations, ‖F̃‖ and
status; where they differ, the largest control-point difference is reported.

With --instructions, the planning of those swings runs once per tree under valgrind's callgrind, its counters
zeroed after a warm-up swing and dumped after the last (`callgrind_control`): instruction counts, which the
load of a shared machine does not change. Writes bench/results/<name>.json and its BENCHMARKS.md section.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result

ONE_THREAD = {"OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
WARM_UP = 1  # the swing planned before the counted ones under callgrind (first-use imports, caches)


def serve(map_path: str, steps_path: str, mode: str = "serve", counted: str = "") -> None:
    """The per-tree process: with mode "serve", plan the swing whose number arrives on each stdin line and
    answer one JSON line; with "callgrind", plan `counted` (comma-separated) between zeroed and dumped
    callgrind counters."""
    import time

    import numpy as np
    from step_plan import merge_swings

    from legplan.stepplan.batch import StepWorker, motion_stance
    from legplan.stepplan.params import StepPlanParams
    from legplan.stepplan.planner import plan_step
    from legplan.stepseq.sequence import read_steps

    seq = merge_swings(read_steps(steps_path))
    worker = StepWorker(seq.robot, map_path, StepPlanParams())

    def plan(i: int):
        stance = motion_stance(seq.stance[i], seq.stance[i + 1], seq.footholds[i], seq.footholds[i + 1])
        return plan_step(worker.robot, worker.distance, seq.q[i], seq.q[i + 1], stance,
                         np.nan_to_num(seq.footholds[i]), worker.params)

    if mode == "callgrind":
        plan(WARM_UP)
        control = ["callgrind_control"]
        subprocess.run([*control, "-z", str(os.getpid())], check=True, capture_output=True)
        for i in counted.split(","):
            plan(int(i))
        subprocess.run([*control, "-d", "counted", str(os.getpid())], check=True, capture_output=True)
        return
    print(json.dumps(len(seq) - 1), flush=True)
    for line in sys.stdin:
        i = int(line)
        cpu = time.process_time()
        result = plan(i)
        cpu = time.process_time() - cpu
        print(json.dumps({"cpu": cpu, "success": bool(result.success), "degree": int(result.degree),
                          "norm": float(result.norm).hex(),
                          "control_points": [float(v).hex() for v in np.ravel(result.control_points)],
                          "degrees": [[d.degree, d.iterations, float(d.norm).hex(), d.status] for d in result.degrees]}),
              flush=True)


def _process(tree: Path, *args: str, **popen) -> subprocess.Popen:
    env = {**os.environ, **ONE_THREAD, "PYTHONPATH": f"{tree}{os.pathsep}{ROOT / 'bench'}"}
    return subprocess.Popen([sys.executable, str(Path(__file__).resolve()), "--serve", *args], env=env,
                            cwd=ROOT / "bench", text=True, **popen)


def side_by_side(trees: dict[str, Path], map_path: Path, steps_path: Path, swings: list[int] | None,
                 rounds: int) -> dict:
    """Every swing of `swings` (None: all) by every tree, in alternation, `rounds` times."""
    workers = {side: _process(tree, str(map_path), str(steps_path), stdin=subprocess.PIPE, stdout=subprocess.PIPE)
               for side, tree in trees.items()}
    total = min(json.loads(w.stdout.readline()) for w in workers.values())
    chosen = list(range(total)) if swings is None else [i for i in swings if i < total]
    runs: dict[str, dict[int, dict]] = {side: {} for side in trees}
    loads = [load_average()]
    for r in range(rounds):
        for n, i in enumerate(chosen):
            for side in (list(trees) if (n + r) % 2 == 0 else list(trees)[::-1]):
                workers[side].stdin.write(f"{i}\n")
                workers[side].stdin.flush()
                answer = json.loads(workers[side].stdout.readline())
                cpu = answer.pop("cpu")
                kept = runs[side].setdefault(i, {**answer, "cpu": []})
                if {k: v for k, v in kept.items() if k != "cpu"} != answer:
                    raise RuntimeError(f"{side} planned swing {i} differently in round {r + 1}")
                kept["cpu"].append(cpu)
        loads.append(load_average())
        print(f"round {r + 1}/{rounds}, load {loads[-1]:.1f}", file=sys.stderr, flush=True)
    for w in workers.values():
        w.stdin.close()
        w.wait()
    return {"swings": chosen, "rounds": rounds, "load": loads,
            "cpu": {side: {i: run["cpu"] for i, run in by_swing.items()} for side, by_swing in runs.items()},
            "comparison": compare(*runs.values())}


def compare(this: dict[int, dict], before: dict[int, dict]) -> dict:
    """Bit for bit per swing, and for those that differ: same path (degrees, iterations, status), largest
    control-point difference."""
    differ = []
    for i, a in this.items():
        b = before[i]
        if {k: v for k, v in a.items() if k != "cpu"} == {k: v for k, v in b.items() if k != "cpu"}:
            continue
        pa, pb = ([float.fromhex(v) for v in run["control_points"]] for run in (a, b))
        gap = max(abs(x - y) for x, y in zip(pa, pb)) if len(pa) == len(pb) else float("inf")
        same_path = [d[:2] + d[3:] for d in a["degrees"]] == [d[:2] + d[3:] for d in b["degrees"]]
        differ.append({"swing": i, "largest_control_point_difference": gap, "same_degrees_iterations_status": same_path,
                       "success": [a["success"], b["success"]]})
    return {"bit_for_bit": len(this) - len(differ), "differ": differ}


def instructions(trees: dict[str, Path], map_path: Path, steps_path: Path, counted: str, work: Path) -> dict:
    """Callgrind's instruction count of planning `counted` per tree (both trees' processes at once)."""
    runs = {}
    for side, tree in trees.items():
        out = work / f"callgrind.{side}"
        env = {**os.environ, **ONE_THREAD, "PYTHONPATH": f"{tree}{os.pathsep}{ROOT / 'bench'}"}
        runs[side] = (out, subprocess.Popen(
            ["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}.%p", sys.executable,
             str(Path(__file__).resolve()), "--serve", str(map_path), str(steps_path), "callgrind", counted],
            env=env, cwd=ROOT / "bench", stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
    counts = {}
    for side, (out, process) in runs.items():
        process.wait()
        dumps = [p for p in out.parent.glob(f"{out.name}.*") if re.search(r"\.\d+\.\d+$", p.name)]
        if len(dumps) != 1:
            raise RuntimeError(f"{side}: expected one counted callgrind dump, found {[p.name for p in dumps]}")
        totals = re.search(r"^(?:summary|totals): (\d+)", dumps[0].read_text(), re.MULTILINE)
        counts[side] = int(totals.group(1))
    return {"swings": counted, "warm_up_swing": WARM_UP, "instructions": counts}


def markdown(result: dict) -> str:
    sides = list(result["trees"])
    ab = result["side_by_side"]
    med = {s: statistics.median(statistics.median(c) for c in ab["cpu"][s].values()) for s in sides}
    total = {s: sum(statistics.median(c) for c in ab["cpu"][s].values()) for s in sides}
    ratios = [statistics.median(ab["cpu"][sides[0]][i]) / statistics.median(ab["cpu"][sides[1]][i])
              for i in ab["cpu"][sides[0]]]
    cmp = ab["comparison"]
    lines = [f"## {result['name']} — whole swings, this tree ({result['code']}) against {result['before_code']} "
             f"(`bench/swing_ab.py`, {result['date']}, {result['machine']}, load {min(ab['load']):.1f}–"
             f"{max(ab['load']):.1f})", "",
             f"{len(ab['swings'])} whole swings of the gap-crossing scenario (scarab2), one process per tree, one BLAS "
             f"thread, swing by swing in alternation, {ab['rounds']} rounds; per swing the median CPU of its rounds.", "",
             "| measure | this tree | before | ratio |", "|---|---|---|---|",
             f"| median over swings of the per-swing CPU [s] | {med[sides[0]]:.4f} | {med[sides[1]]:.4f} | "
             f"{med[sides[0]] / med[sides[1]]:.3f} |",
             f"| sum over swings [s] | {total[sides[0]]:.2f} | {total[sides[1]]:.2f} | "
             f"{total[sides[0]] / total[sides[1]]:.3f} |",
             f"| median of the per-swing ratios | | | {statistics.median(ratios):.3f} |"]
    if result.get("instructions"):
        ins = result["instructions"]["instructions"]
        lines.append(f"| instructions, swings {result['instructions']['swings']} (callgrind) | {ins[sides[0]]:.4e} | "
                     f"{ins[sides[1]]:.4e} | {ins[sides[0]] / ins[sides[1]]:.3f} |")
    worst = max((d["largest_control_point_difference"] for d in cmp["differ"]), default=0.0)
    lines += ["", f"Results: {cmp['bit_for_bit']} of {len(ab['swings'])} swings bit for bit (control points, ‖F̃‖, "
                  f"success, degree, per degree LM iterations, ‖F̃‖ and status)"
                  + (f"; {len(cmp['differ'])} differ, largest control-point difference {worst:.3e}" if cmp["differ"]
                     else ".")]
    return "\n".join(lines)


def main(argv=None) -> int:
    if argv is None and len(sys.argv) > 1 and sys.argv[1] == "--serve":
        serve(*sys.argv[2:])
        return 0
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", type=Path, required=True, help="reference source tree (e.g. a `git archive`)")
    ap.add_argument("--before-code", default="", help="the reference's commit, for the report")
    ap.add_argument("--map", type=Path)
    ap.add_argument("--steps", type=Path)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--swings", default="", help="FIRST:STOP of the whole swings (default: all)")
    ap.add_argument("--instructions", default="", help="swings planned under callgrind, comma-separated")
    ap.add_argument("--name", default="swing_ab", help="result and BENCHMARKS.md section name")
    ap.add_argument("--no-append", action="store_true", help="do not update BENCHMARKS.md")
    args = ap.parse_args(argv)
    trees = {"this": ROOT, "before": args.before.resolve()}
    swings = None
    if args.swings:
        first, stop = (int(v) for v in args.swings.split(":"))
        swings = list(range(first, stop))
    with tempfile.TemporaryDirectory() as tmp:
        map_path, steps_path = args.map, args.steps
        if map_path is None or steps_path is None:
            from step_plan import scenario

            map_path, steps_path = scenario(Path(tmp), "scarab2", (-0.6, 0.0, 0.0), (0.6, 0.0, 0.0))
        result = {"name": args.name, "date": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="minutes"),
                  "machine": machine(), "code": code_version(), "before_code": args.before_code or str(args.before),
                  "trees": {k: str(v) for k, v in trees.items()}}
        if args.instructions:
            result["instructions"] = instructions(trees, Path(map_path), Path(steps_path), args.instructions, Path(tmp))
            print(f"instructions: {result['instructions']['instructions']}", file=sys.stderr)
        result["side_by_side"] = side_by_side(trees, Path(map_path), Path(steps_path), swings, args.rounds)
    write_result(args.name, result)
    text = markdown(result)
    print(text)
    if not args.no_append:
        update_benchmarks(args.name, text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
