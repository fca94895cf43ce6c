"""Benchmark of `legplan step plan` against Table II of the Bézier step-planning paper.

    .venv/bin/python bench/step_plan.py [--map map.h5 --steps steps.h5] [--jobs 1] [--profile-steps 5]
                                        [--stall-window 10] [--compare REV]

Without --map/--steps the gap-crossing scenario is built (`legplan map build maps/gap_crossing.yaml`)
and a step sequence generated (`legplan steps generate`, scarab2). Every consecutive pair is planned
on one core per worker (default 1 worker, as in the paper's single-thread timings); writes
bench/results/step_plan.json and replaces its section of BENCHMARKS.md (Table II rows, ours vs paper,
plus the time breakdown) with machine, date and load average. With --stall-window W the whole swings are
planned a second time with the opt-in SolveLM stall stop (`stall_window=W`, a departure from
Algorithm 1) and reported as a third column. A profiled pass over a few non-trivial steps
attributes the time to kinematics, terrain distance, residual terms, JᵀJ assembly, Schur +
factorisation. With --compare REV, git revision REV (exported with `git archive`) and this tree
then plan their own generated sequences in two processes, step by step in alternation, so that
both see the same load of the shared machine (`compare_interleaved`); a second table compares
their planning times (wall and CPU).
Every step is judged on every constraint on the dense re-sampling (`legplan.stepplan.measure`);
the worst shortfall per constraint is reported with its tolerance.
"""

from __future__ import annotations

import argparse
import cProfile
import dataclasses
import datetime
import json
import os
import pstats
import subprocess
import sys
import tempfile
from pathlib import Path

for _var in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")  # one core per planning process, as the targets are stated

import numpy as np  # noqa: E402

from common import ROOT, machine, update_benchmarks, write_result  # noqa: E402

PAPER = {"steps_planned": 89, "steps_succeeded": 85, "worst_violation": 1.73e-3, "mean_time": 24.3,
         "median_time": 6.7, "mean_time_below_50s": 6.7, "mean_time_1s_to_50s": 11.1}
LABELS = {"steps_planned": "Steps planned", "steps_succeeded": "Steps succeeded",
          "worst_violation": "Worst constraint violation (dense stance-foot slip) [mm]",
          "mean_time": "Average planning time [s]", "median_time": "Median planning time [s]",
          "mean_time_below_50s": "Average, t < 50 s [s]", "mean_time_1s_to_50s": "Average, 1 s < t < 50 s [s]"}
# where the time goes: (label, substring of "file:function" in the profile), cumulative seconds
PROFILE_GROUPS = (("planner kinematics: points (stepplan.kinematics, all samples at once)", "stepplan/kinematics.py:points"),
                  ("planner kinematics: Jacobians of stance feet and active spheres", "stepplan/kinematics.py:jacobians"),
                  ("planner kinematics: CoM Jacobian", "stepplan/kinematics.py:com_jacobian"),
                  ("terrain distance lookups", "columns.py:_evaluate"),
                  ("constraint rows (values, and Jacobians where active)", "stepplan/block.py:_rows"),
                  ("structured JᵀJ (kron) terms of the compact rows", "solve/curve.py:curve_terms"),
                  ("normal-equation assembly", "solve/problem.py:_finish"),
                  ("trial points (early-reject residual)", "solve/problem.py:trial_norm"),
                  ("Schur set-up per linearisation (eigh, U)", "solve/schur.py:set_matrix"),
                  ("Schur reduced matrix + factorisation per λ", "solve/schur.py:refactor"),
                  ("triangular solves", "solve/schur.py:solve"),
                  ("dense re-check (validator, FCL)", "stepplan/measure.py:dense_check"))


def scenario(workdir: Path, robot_name: str, start, goal) -> tuple[Path, Path]:
    """map.h5 of maps/gap_crossing.yaml and a generated steps.h5 (the library calls behind
    `legplan map build` and `legplan steps generate`)."""
    from legplan.robots import load_robot
    from legplan.stepseq.generate import generate_steps
    from legplan.stepseq.sequence import write_steps
    from legplan.terrain.spec import build_map
    from legplan.terrain.terrain_map import save_map
    from legplan.validate.checks import Validator

    map_path, steps_path = workdir / "map.h5", workdir / "steps.h5"
    terrain = build_map(ROOT / "maps/gap_crossing.yaml")
    save_map(terrain, map_path)
    robot = load_robot(robot_name)
    seq, generated, checks = generate_steps(robot, terrain, start, goal, validator=Validator(robot, terrain))
    print(f"generated {len(seq)} configurations (reached goal: {generated.success} {generated.reason[:80]})",
          file=sys.stderr)
    write_steps(steps_path, seq, checks)
    return map_path, steps_path


def merge_swings(seq):
    """The sequence without the mid-swing configurations: where q_i lifts exactly one leg of q_{i-1}
    and q_{i+1} puts that leg down again, drop q_i, so the pair (q_{i-1}, q_{i+1}) is a whole swing
    from foothold to foothold (the paper's configurations 'where a leg switches between swinging and
    supporting'); the planner then has to find the foot's lift itself."""
    from legplan.stepseq.sequence import StepSequence

    keep = [0]
    for i in range(1, len(seq) - 1):
        lifted = seq.stance[i - 1] & ~seq.stance[i]
        same_otherwise = np.array_equal(seq.stance[i - 1] & ~lifted, seq.stance[i])
        if lifted.sum() == 1 and same_otherwise and np.array_equal(seq.stance[i + 1], seq.stance[i - 1]):
            continue
        keep.append(i)
    keep.append(len(seq) - 1)
    return StepSequence(q=seq.q[keep], stance=seq.stance[keep], footholds=seq.footholds[keep], robot=seq.robot,
                        robot_sha256=seq.robot_sha256, leg_names=seq.leg_names, joint_names=seq.joint_names)


def profile_breakdown(seq, map_path, params, indices) -> dict[str, float]:
    from legplan.stepplan.batch import plan_sequence

    profiler = cProfile.Profile()
    profiler.enable()
    plan_sequence(seq, map_path, params, indices)
    profiler.disable()
    stats = pstats.Stats(profiler).stats
    total = sum(tt for (_, _, _), (_, _, tt, _, _) in stats.items())
    out = {"total": total}
    for label, key in PROFILE_GROUPS:
        out[label] = sum(ct for (file, _, fn), (_, _, _, ct, _) in stats.items() if f"{file}:{fn}".endswith(key)
                         or (key.split(":")[0] in file and fn == key.split(":")[1]))
    return out


PAIR_WORKER = r"""
import json, sys, tempfile, time
from pathlib import Path
sys.path.insert(0, "bench")
import numpy as np
from step_plan import merge_swings, scenario
from legplan.stepplan.batch import StepWorker, motion_stance
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import plan_step
from legplan.stepseq.sequence import read_steps
with tempfile.TemporaryDirectory() as work:
    map_path, steps_path = scenario(Path(work), *json.loads(sys.argv[1]))
    generated = read_steps(steps_path)
    variants = {"as generated": generated, "whole swings": merge_swings(generated)}
    worker = StepWorker(generated.robot, str(map_path), StepPlanParams())
    distance = getattr(worker, "distance", worker.terrain.sdf)  # what this revision's worker plans with
    print(json.dumps({name: len(seq) - 1 for name, seq in variants.items()}), flush=True)
    for line in sys.stdin:
        name, i = json.loads(line)
        seq = variants[name]
        stance = motion_stance(seq.stance[i], seq.stance[i + 1], seq.footholds[i], seq.footholds[i + 1])
        cpu = time.process_time()
        footholds = np.nan_to_num(seq.footholds[i])
        plan = plan_step(worker.robot, distance, seq.q[i], seq.q[i + 1], stance, footholds, worker.params)
        print(json.dumps({"seconds": plan.seconds, "cpu": time.process_time() - cpu, "success": plan.success}),
              flush=True)
"""


def compare_interleaved(revision: str, robot: str, start, goal) -> dict:
    """Planning times of this tree and of git revision `revision` (exported with `git archive`), each
    in its own process on its own generated sequence, requested step by step in alternation (the
    order swapped every step) so both see the same load of the shared machine: {side: {variant:
    [{"seconds", "cpu", "success"}, ...]}} (planning only, the planner's own success)."""
    with tempfile.TemporaryDirectory() as tree:
        archive = subprocess.run(["git", "archive", revision], cwd=ROOT, capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", tree], input=archive, check=True)
        sides = {}
        for side, root in ((revision, tree), ("this tree", str(ROOT))):
            sides[side] = subprocess.Popen([sys.executable, "-c", PAIR_WORKER, json.dumps([robot, start, goal])],
                                           cwd=root, env={**os.environ, "PYTHONPATH": root}, text=True,
                                           stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        counts = {side: json.loads(worker.stdout.readline()) for side, worker in sides.items()}
        out = {side: {variant: [] for variant in counts[side]} for side in sides}
        for variant in counts[revision]:
            for i in range(max(counts[side][variant] for side in sides)):
                for side in (list(sides) if i % 2 == 0 else list(sides)[::-1]):
                    if i < counts[side][variant]:
                        sides[side].stdin.write(json.dumps([variant, i]) + "\n")
                        sides[side].stdin.flush()
                        out[side][variant].append(json.loads(sides[side].stdout.readline()))
        for worker in sides.values():
            worker.stdin.close()
            worker.wait()
    return out


def column_differences(variants: dict) -> str:
    """Where the 'as generated' and 'whole swings' columns (and the paper's) differ, from the degrees reached."""
    straight = {name: sum(d == 1 for d in info["degrees"]) for name, info in variants.items()}
    counts = "; ".join(f"{name}: {straight[name]} of {len(info['degrees'])}" for name, info in variants.items())
    return ("Where the columns differ: a step that ends at degree 1 is the straight line between its two "
            f"configurations (no free control point; Algorithm 1 starts there) — {counts}. The 'as generated' "
            "column is mostly such straight-line steps: the generator's lifted mid-swing configuration halves every "
            "swing and most halves are already feasible as a line, so its times measure little of the optimizer. "
            "'whole swings' is the column to set against the paper's.")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--map", type=Path)
    ap.add_argument("--steps", type=Path)
    ap.add_argument("--robot", default="scarab2")
    ap.add_argument("--start", type=float, nargs=3, default=(-0.6, 0.0, 0.0))
    ap.add_argument("--goal", type=float, nargs=3, default=(0.6, 0.0, 0.0))
    ap.add_argument("--jobs", type=int, default=1)
    ap.add_argument("--param", action="append", default=[], help="key=value planner override")
    ap.add_argument("--profile-steps", type=int, default=5, help="non-trivial steps in the profiled pass")
    ap.add_argument("--stall-window", type=int, default=0,
                    help="also plan the whole swings with the opt-in SolveLM stall stop (stall_window=W)")
    ap.add_argument("--no-append", action="store_true", help="do not update BENCHMARKS.md")
    ap.add_argument("--compare", metavar="REV",
                    help="also time git revision REV against this tree, step by step in alternation")
    args = ap.parse_args(argv)

    from legplan.batch import Backend, Task, run_batch
    from legplan.stepplan.batch import StepWorker, failed_item, plan_item, step_items, table2
    from legplan.stepplan.measure import requirements
    from legplan.stepplan.params import StepPlanParams
    from legplan.stepseq.sequence import read_steps
    from legplan.validate.judge import CONSTRAINTS

    params = StepPlanParams.from_overrides(dict(p.split("=", 1) for p in args.param))
    load_before = os.getloadavg()
    variants = {}
    with tempfile.TemporaryDirectory() as tmp:
        if args.map is None or args.steps is None:
            map_path, steps_path = scenario(Path(tmp), args.robot, args.start, args.goal)
        else:
            map_path, steps_path = args.map, args.steps
        generated = read_steps(steps_path)
        runs = [("as generated", generated, params), ("whole swings", merge_swings(generated), params)]
        if args.stall_window:
            stall = dataclasses.replace(params, stall_window=args.stall_window)
            runs.append((f"whole swings, stall_window={args.stall_window}", runs[1][1], stall))
        for name, seq, run_params in runs:
            task = Task(plan_item, failed_item, StepWorker, (seq.robot, str(map_path), run_params))
            with run_batch(task, step_items(seq, range(len(seq) - 1)), output=Path(tmp) / "motion.h5",
                           identity={}, backend=Backend(jobs=args.jobs),
                           progress=lambda d, n, m: print(f"\r{d}/{n} {m}", end="", file=sys.stderr)) as records:
                pass
            print(file=sys.stderr)
            variants[name] = (seq, records)
        seq, records = variants["whole swings"]
        hard = sorted((r for r in records if r.get("degree", 1) > 1), key=lambda r: -r["seconds"])
        profiled = sorted(r["index"] for r in hard[:args.profile_steps])
        breakdown = profile_breakdown(seq, map_path, params, profiled) if profiled else {}
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "robot": generated.robot,
              "map": str(map_path if args.map else "maps/gap_crossing.yaml"), "params": params.as_dict(),
              "jobs": args.jobs, "paper": PAPER, "profile_steps_whole_swings": profiled, "profile_s": breakdown,
              "load_average_1_5_15": {"before": load_before, "after": os.getloadavg()}, "variants": {}}
    lines = [f"## step_plan — Bézier + LM single-step planner vs paper Table II ({result['date']})\n",
             f"Machine: {result['machine']}, load average (1/5/15 min) {' / '.join(f'{x:.1f}' for x in load_before)} "
             f"before, {' / '.join(f'{x:.1f}' for x in result['load_average_1_5_15']['after'])} after (shared machine); "
             f"robot {generated.robot}; {result['map']} with the sequence of "
             f"`legplan steps generate` ({len(generated)} configurations); --jobs {args.jobs} (one BLAS thread); params "
             f"{json.dumps({k: v for k, v in params.as_dict().items() if k in ('samples', 'max_degree', 'max_iterations', 'epsilon', 'eps_num', 'slack_fraction')})}. "
             "'as generated': every consecutive pair (the generator inserts a lifted configuration mid-swing); "
             "'whole swings': mid-swing configurations dropped, each pair a full foothold-to-foothold swing as in the "
             "paper. Paper: C++/MKL Pardiso, i7-10700 @ 4.8 GHz, 89 steps.\n",
             "| Table II row | " + " | ".join(f"ours, {name}" for name in variants) + " | paper |",
             "|---|" + "---|" * (len(variants) + 1)]
    summaries = {}
    for name, (seq, records) in variants.items():
        summary = {k: (v[0] if isinstance(v, tuple) else v) for k, v in table2(records).items()}
        summaries[name] = summary
        timings = {k: float(sum(r.get("timings", {}).get(k, 0.0) for r in records))
                   for k in ("evaluate", "assemble", "factorize", "solve")}
        result["variants"][name] = {
            "summary": summary, "lm_timings_total_s": timings,
            "degrees": [int(r.get("degree", 0)) for r in records], "times_s": [float(r["seconds"]) for r in records],
            "failures": {int(r["index"]): r["reason"] for r in records if not r["success"]}}
    for key, label in LABELS.items():
        scale = 1e3 if key == "worst_violation" else 1.0
        cells = [f"{summaries[name][key] * scale:.4g}" for name in variants]
        lines.append(f"| {label} | {' | '.join(cells)} | {PAPER[key] * scale:.4g} |")
    tolerance = requirements(params).tolerances()
    for name, info in result["variants"].items():
        summary, timings = info["summary"], info["lm_timings_total_s"]
        lm_total = sum(timings.values())
        worst = ", ".join(f"{key} {summary[f'worst_shortfall_{key}'] * 1e3:.4g} m{unit} (tolerance "
                          f"{tolerance[key] * 1e3:g})" for key, unit in CONSTRAINTS.items())
        lines.append(f"\n{name}: {len(info['failures'])} steps failed; dense re-check (every constraint, exact terrain "
                     f"distance) worst shortfall, ≤ 0 kept: {worst}; "
                     f"worst CoM margin {summary['worst_com_margin'] * 1e3:.2f} mm; "
                     f"degree reached per step (count for d = 0..): {np.bincount(info['degrees']).tolist()}; "
                     f"max time {max(info['times_s']):.2f} s; LM time split: "
                     + ", ".join(f"{k} {v:.2f} s ({v / max(lm_total, 1e-12):.0%})" for k, v in timings.items()))
    lines.append("\n" + column_differences(result["variants"]))
    if args.compare:
        load = os.getloadavg()
        result["compare"] = compare_interleaved(args.compare, args.robot, args.start, args.goal)
        lines += [f"\nSame session, {args.compare} (before) vs this tree, each planning its own generated sequence in "
                  "its own process, steps requested in alternation (order swapped every step); planning time only "
                  f"(wall and process CPU), successes by the planner's own test; load average "
                  f"{' / '.join(f'{x:.1f}' for x in load)} before, {' / '.join(f'{x:.1f}' for x in os.getloadavg())} "
                  "after.\n", "| variant | code | steps | planner successes | median wall [s] | mean wall [s] | "
                  "median CPU [s] | mean CPU [s] |", "|---|---|---|---|---|---|---|---|"]
        for variant in result["compare"][args.compare]:
            for side, runs in result["compare"].items():
                wall = [r["seconds"] for r in runs[variant]]
                cpu = [r["cpu"] for r in runs[variant]]
                lines.append(f"| {variant} | {side} | {len(wall)} | {sum(r['success'] for r in runs[variant])} | "
                             f"{np.median(wall):.3f} | {np.mean(wall):.3f} | {np.median(cpu):.3f} | {np.mean(cpu):.3f} |")
    write_result("step_plan", result)
    if breakdown:
        lines.append(f"\nProfile of the {len(profiled)} slowest whole-swing steps {profiled} (cumulative s, groups "
                     f"overlap; total {breakdown['total']:.2f} s): "
                     + "; ".join(f"{k} {v:.2f}" for k, v in breakdown.items() if k != "total"))
    text = "\n".join(lines) + "\n"
    print(text)
    if not args.no_append:
        update_benchmarks("step_plan", text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
