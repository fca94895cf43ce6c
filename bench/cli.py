"""Benchmark of the one-shot command: process CPU of `legplan dyn plan` on bench/dyn.py's cases (issue 38).

    .venv/bin/python bench/cli.py [--repeats 3] [--cases KEY,KEY] [--before PATH] [--no-append]
                                  [--jobs-steps 60:80] [--jobs-repeats 3] [--skip-dyn] [--skip-jobs]
                                  [--swings 12] [--step-map map.h5 --step-sequence steps.h5]

The side-by-side run of issue 38 (main's code as the reference, e.g. `git worktree add --detach
/tmp/speed_ref main`):

    nice -n 5 .venv/bin/python bench/cli.py --before /tmp/speed_ref --jobs-repeats 2

For every case of bench/dyn.py (`CASES`: TOWR's cases and stairs) the whole command
`legplan dyn plan MAP --gait --strides --duration --start --goal -o traj.h5 -q` (run as the
`legplan` console script runs it, TOWR's formulation: `--costs none`, heuristic initializer,
independent check on) runs in a fresh process with one BLAS thread; its CPU time (user + system, of
the process and anything it started: `resource.getrusage(RUSAGE_CHILDREN)` around the run) is the
figure, start-up included. Each run is split into
  * start-up: a fresh process that imports exactly the modules that case's command imported (in the
    same order) and ends as the command does: interpreter, imports and exit;
  * solve: CPU inside `legplan.dyn.planner.solve_augmented_lagrangian` (all stages), measured in the
    same run by a wrapper the probe installs (`PROBE`);
  * the rest: whole − start-up − solve (reading the robot and the map, building the problem,
    sampling, the independent check, the work file, writing traj.h5).
Median of --repeats runs each (3 at least). Every child runs with Python's bytecode cache in a folder
of the run (`PYTHONPYCACHEPREFIX`; `PYTHONDONTWRITEBYTECODE` removed), as an installed package runs
from its compiled modules: otherwise a tree whose sources have no cache would compile every module
it imports on every run. The first, untimed run of each command (the module list) fills it.
`legplan.cache`'s store of filtered terrain grids is a folder of the run too (`LEGPLAN_CACHE_DIR`),
filled by that first run, so the timed runs are repeated runs on the same map; the "empty store"
row is this tree's whole command with the store emptied before each run (the first run on a map). `legplan --version` (interpreter + click) is measured in
the same run. With --before PATH, the legplan tree at PATH (e.g. a checkout of the main branch) runs
the same commands in alternation with this tree (run i of both back to back), so both see the same
load; its column is the reference measured side by side.

`--jobs 2` against `--jobs 1`: the whole command `legplan step plan MAP STEPS --steps A:B` on the
gap-crossing scenario (bench/step_plan.py's `scenario`: maps/gap_crossing.yaml, scarab2, the
generated sequence) in two variants: the pairs as generated (issue 38's measurement: mostly
millisecond steps) and whole swings (bench/step_plan.py's `merge_swings`: every item a full swing,
the ≥ 0.2 s items of the target). Wall time and process CPU of each, --jobs 1 and --jobs 2 in
alternation, median of --jobs-repeats runs; the speed-up is the ratio of the median wall times.
On a machine whose two cores are busy with other work no pool can approach 2×: the load average
is recorded with it. (`step plan --jobs N` forks its workers from the command once it has read its
inputs and built the task context, `legplan.batch.fork_workers`; a tree that prestarts a fork server
instead pays for the server's imports and context in its --jobs 2 CPU column.) With --before, that
tree's commands run the same comparison, interleaved with this tree's runs (its --jobs 2 is its own
batch layer's).

Whole swings, this tree against --before: with --before, --swings N whole swings of that scenario (every
k-th of them, spread over the sequence) are planned by one long-lived process per tree (`SWING_WORKER`:
the planner call of `legplan step plan`, `plan_step`, on the tree's own code), item by item in
alternation, order swapped every item; per item the CPU of the planning call and a digest of its
result (control points, degree, norm, success), so the table says whether both trees planned the same
swings bit for bit; where they did not, whether every swing reached the same degree with the same LM
iterations per degree and success, and the largest control-point difference (the tolerance is
`CONTROL_POINT_TOLERANCE`).

Start-up floor: in the same run, the CPU of the interpreter alone (`python -c pass`) and of the
interpreter importing only the libraries a `dyn plan` cannot do without (`FLOOR`: numpy, scipy.sparse,
CHOLMOD, pinocchio, h5py, click, PyYAML, after legplan's package init as the command imports them); the
start-up column minus the latter is what legplan's own modules and the deferrable imports cost.

TOWR's figures are the issue's (TOWR rebuilt on this machine, process CPU, another — idle — day):
TOWR cannot run here, so they are context for the reader, not a ratio taken in one run.

Writes bench/results/cli.json and replaces the `cli` section of BENCHMARKS.md (not with --no-append);
with --skip-jobs the previous result's `--jobs` comparison is carried over, marked with its run.
"""

from __future__ import annotations

import argparse
import datetime
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from common import ROOT, become_subreaper, code_version, load_average, machine, reap_orphans, update_benchmarks, write_result

# Issue 38: TOWR's whole-process CPU (s) on this machine's idle day, same cases (another day's figures).
TOWR_PROCESS_CPU = {"flat_trot": 0.80, "flat_walk": 1.87, "single_walk": 2.58, "single_trot": 6.92,
                    "double_walk": 3.99, "flat_trot_2": None}
TOWR_NOTES = {"flat_trot_2": "TOWR fails after 40 s"}
THREADS = {name: "1" for name in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS")}

# Runs `legplan` as the console script does (legplan.cli.main:main), with the solve's CPU written
# to $LEGPLAN_BENCH_SOLVE by an atexit handler (main runs atexit handlers before it ends).
PROBE = r"""
import atexit, os, time
import legplan.dyn.planner as planner
spent = [0.0]
original = planner.solve_augmented_lagrangian
def timed(*args, **kwargs):
    t0 = time.process_time()
    try:
        return original(*args, **kwargs)
    finally:
        spent[0] += time.process_time() - t0
planner.solve_augmented_lagrangian = timed
atexit.register(lambda: open(os.environ["LEGPLAN_BENCH_SOLVE"], "w").write(repr(spent[0])))
"""
# The `legplan` console script of the tree (`main`, or `cli` in trees before it had `main`).
ENTRY = r"""
import sys
sys.argv[0] = "legplan"
try:
    from legplan.cli.main import main
except ImportError:
    from legplan.cli.main import cli as main
main()
"""

# Prints the modules a command leaves in sys.modules, in import order (not timed).
MODULES = r"""
import json, os, sys
before = set(sys.modules)
from legplan.cli.main import cli
try:
    cli(sys.argv[1:], prog_name="legplan")
except SystemExit:
    pass
open(os.environ["LEGPLAN_BENCH_MODULES"], "w").write(json.dumps([m for m in sys.modules if m not in before]))
"""

# Imports the given modules in order, then ends as that tree's console script does (`main`: atexit
# handlers, no module teardown; a tree without `main`: the interpreter's normal exit), with the
# garbage collector set as that tree's `main` sets it.
STARTUP = r"""
import atexit, gc, importlib, json, os, sys
import legplan.cli.main
if hasattr(legplan.cli.main, "YOUNG_OBJECTS"):  # as the console script sets the collector
    gc.set_threshold(legplan.cli.main.YOUNG_OBJECTS, *gc.get_threshold()[1:])
for name in json.load(open(sys.argv[1])):
    try:
        importlib.import_module(name)
    except Exception:
        pass  # a module that only exists inside another's import (e.g. Cython's runtime)
import legplan.cli.main
if hasattr(legplan.cli.main, "main"):
    atexit._run_exitfuncs()
    sys.stdout.flush()
    os._exit(0)
"""

# Plans whole swings of a given map and sequence on demand (stdin: swing index; stdout: one JSON line).
SWING_WORKER = r"""
import hashlib, json, sys, time
sys.path.insert(0, "bench")
import numpy as np
from step_plan import merge_swings
from legplan.stepplan.batch import StepWorker, motion_stance
from legplan.stepplan.params import StepPlanParams
from legplan.stepplan.planner import plan_step
from legplan.stepseq.sequence import read_steps
seq = merge_swings(read_steps(sys.argv[2]))
worker = StepWorker(seq.robot, sys.argv[1], StepPlanParams())
print(json.dumps(len(seq) - 1), flush=True)
for line in sys.stdin:
    i = json.loads(line)
    stance = motion_stance(seq.stance[i], seq.stance[i + 1], seq.footholds[i], seq.footholds[i + 1])
    footholds = np.nan_to_num(seq.footholds[i])
    cpu = time.process_time()
    plan = plan_step(worker.robot, worker.distance, seq.q[i], seq.q[i + 1], stance, footholds, worker.params)
    cpu = time.process_time() - cpu
    digest = hashlib.sha256(np.ascontiguousarray(plan.control_points).tobytes() + repr(
        (plan.degree, plan.norm, plan.success, plan.reason)).encode()).hexdigest()[:16]
    print(json.dumps({"cpu": cpu, "success": bool(plan.success), "digest": digest, "degree": int(plan.degree),
                      "iterations": [int(d.iterations) for d in plan.degrees], "norm": float(plan.norm),
                      "control_points": np.asarray(plan.control_points).tolist()}), flush=True)
"""
# Imports only the libraries a `dyn plan` cannot do without, as legplan imports them (its package init
# first: it keeps scipy.sparse from importing numpy's unused submodules), and ends as the console script
# does (atexit handlers, no module teardown) — the start-up floor.
FLOOR = ("import atexit, os, legplan, numpy, scipy.sparse, sksparse.cholmod, pinocchio, h5py, click, yaml\n"
         "atexit._run_exitfuncs()\nos._exit(0)")
CONTROL_POINT_TOLERANCE = 1e-9  # largest control-point difference (x units) counted as the same swing


def child_cpu(argv, env) -> tuple[float, subprocess.CompletedProcess]:
    """CPU seconds (user + system) of running `argv` to its end, its children included."""
    cpu, _, done = child_run(argv, env)
    return cpu, done


def child_run(argv, env) -> tuple[float, float, subprocess.CompletedProcess]:
    """(CPU seconds, wall seconds, result) of running `argv` to its end, its children included. It
    runs in the tree of `env`'s PYTHONPATH: `python -c` puts the working directory first on sys.path.

    Every process the command started counts, also those it leaves to end after it (a `--jobs N`
    fork server and the workers it reaped): this process is a child subreaper (`main`), so they come
    back to it when the command ends, and their CPU time is added once they are reaped here."""
    before, wall = resource.getrusage(resource.RUSAGE_CHILDREN), time.perf_counter()
    done = subprocess.run(argv, env=env, cwd=env["PYTHONPATH"], capture_output=True, text=True)
    wall = time.perf_counter() - wall
    reap_orphans()
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall, done


# Set by `main` to folders of the run: the bytecode cache and legplan.cache's store (module docstring).
RUN_ENVIRONMENT: dict[str, str] = {}


def environment(tree: Path, **extra) -> dict:
    env = {**os.environ, **THREADS, **RUN_ENVIRONMENT, "PYTHONPATH": str(tree), **extra}
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def command(case, map_path: Path, out: Path) -> list[str]:
    args = ["dyn", "plan", str(map_path), "--gait", case["gait"], "--strides", str(case["strides"]),
            "--duration", str(case["duration"]), "--start", *map(str, case["start"]), "--goal",
            *map(str, case["goal"]), "-o", str(out), "--overwrite", "-q"]
    return args


def run_once(tree: Path, args: list[str], work: Path, modules: Path, **extra) -> dict:
    """One whole command and its split (see the module docstring); `extra` environment variables."""
    solve_file = work / "solve.txt"
    solve_file.unlink(missing_ok=True)
    whole, done = child_cpu([sys.executable, "-c", PROBE + ENTRY, *args],
                            environment(tree, LEGPLAN_BENCH_SOLVE=str(solve_file), **extra))
    startup, _ = child_cpu([sys.executable, "-c", STARTUP, str(modules)], environment(tree))
    solve = float(solve_file.read_text()) if solve_file.exists() else float("nan")
    return {"whole": whole, "startup": startup, "solve": solve, "rest": whole - startup - solve,
            "exit": done.returncode, "stderr": done.stderr.strip()[-300:]}


def module_list(tree: Path, args: list[str], path: Path, **extra) -> int:
    subprocess.run([sys.executable, "-c", MODULES, *args], env=environment(tree, LEGPLAN_BENCH_MODULES=str(path), **extra),
                   cwd=tree, check=False, capture_output=True)
    return len(json.loads(path.read_text())) if path.exists() else 0


def medians(runs: list[dict]) -> dict:
    keys = ("whole", "startup", "solve", "rest")
    return {**{key: statistics.median(r[key] for r in runs) for key in keys},
            "runs_whole": [r["whole"] for r in runs], "exit": [r["exit"] for r in runs]}


def jobs_comparison(work: Path, step_range: str, repeats: int, map_path=None, steps_path=None, trees=None) -> dict:
    """`legplan step plan --steps step_range` with --jobs 1 and --jobs 2 in alternation, on the pairs
    as generated and on whole swings (see the module docstring), for every tree of `trees` (default: this
    one), the trees' runs interleaved so that they see the same load."""
    from step_plan import merge_swings, scenario

    from legplan.robots import load_robot
    from legplan.stepseq.sequence import read_steps, write_steps
    from legplan.terrain import load_map
    from legplan.validate.checks import Validator

    trees = trees or {"this tree": ROOT}
    if map_path is None or steps_path is None:
        map_path, steps_path = scenario(work, "scarab2", (-0.6, 0.0, 0.0), (0.6, 0.0, 0.0))
    swings = merge_swings(read_steps(steps_path))
    swings_path = work / "swings.h5"
    checks = Validator(load_robot(swings.robot), load_map(map_path)).check(swings.q, swings.stance, swings.footholds)
    write_steps(swings_path, swings, checks)
    out = {"steps": step_range, "variants": {}, "others": {side: {} for side in trees if side != "this tree"}}
    for variant, path in (("as generated", steps_path), ("whole swings", swings_path)):
        runs = {(side, jobs): [] for side in trees for jobs in (1, 2)}
        for i in range(repeats):
            for side, jobs in (list(runs) if i % 2 == 0 else list(runs)[::-1]):
                motion = work / f"motion-{side.replace(' ', '-')}-{jobs}.h5"
                argv = [sys.executable, "-c", ENTRY, "step", "plan", str(map_path), str(path), "--steps", step_range,
                        "--jobs", str(jobs), "-o", str(motion), "--overwrite", "-q"]
                cpu, wall, done = child_run(argv, environment(trees[side]))
                runs[(side, jobs)].append({"cpu": cpu, "wall": wall, "exit": done.returncode, "load": load_average()})
        import h5py
        for side in trees:
            with h5py.File(work / f"motion-{side.replace(' ', '-')}-1.h5", "r") as f:
                seconds = [float(f["steps"][k].attrs["seconds"]) for k in sorted(f["steps"])]
            entry = {str(jobs): {"wall": statistics.median(r["wall"] for r in runs[(side, jobs)]),
                                 "cpu": statistics.median(r["cpu"] for r in runs[(side, jobs)]),
                                 "runs": runs[(side, jobs)]} for jobs in (1, 2)}
            entry["speedup"] = entry["1"]["wall"] / entry["2"]["wall"]
            entry["item_seconds_jobs1_last_run"] = seconds
            (out["variants"] if side == "this tree" else out["others"][side])[variant] = entry
            print(f"step plan --steps {step_range} {variant}, {side}: --jobs 1 wall {entry['1']['wall']:.2f} s cpu "
                  f"{entry['1']['cpu']:.2f} s; --jobs 2 wall {entry['2']['wall']:.2f} s cpu {entry['2']['cpu']:.2f} s; "
                  f"speed-up {entry['speedup']:.2f}x", flush=True)
    return out


def swings_comparison(trees: dict, map_path: Path, steps_path: Path, count: int) -> dict:
    """Whole swings planned by each tree's `SWING_WORKER`, item by item in alternation (module docstring)."""
    workers = {side: subprocess.Popen([sys.executable, "-c", SWING_WORKER, str(map_path), str(steps_path)],
                                      cwd=tree, env=environment(tree), text=True, stdin=subprocess.PIPE,
                                      stdout=subprocess.PIPE) for side, tree in trees.items()}
    total = min(json.loads(w.stdout.readline()) for w in workers.values())
    chosen = sorted({int(round(k)) for k in [i * (total - 1) / max(count - 1, 1) for i in range(count)]})
    runs = {side: [] for side in trees}
    for n, i in enumerate(chosen):
        for side in (list(trees) if n % 2 == 0 else list(trees)[::-1]):
            workers[side].stdin.write(json.dumps(i) + "\n")
            workers[side].stdin.flush()
            runs[side].append({"swing": i, **json.loads(workers[side].stdout.readline()), "load": load_average()})
    for w in workers.values():
        w.stdin.close()
        w.wait()
    out = {"swings": chosen, "runs": runs, "median_cpu": {side: statistics.median(r["cpu"] for r in rs)
                                                          for side, rs in runs.items()}}
    sides = list(trees)
    pairs = list(zip(runs[sides[0]], runs[sides[1]]))
    out["same_results"] = all(a["digest"] == b["digest"] for a, b in pairs)
    out["same_path"] = all(a["degree"] == b["degree"] and a["iterations"] == b["iterations"]
                           and a["success"] == b["success"] for a, b in pairs)
    out["control_point_difference"] = max(
        (float(np.max(np.abs(np.subtract(a["control_points"], b["control_points"]))))
         if np.shape(a["control_points"]) == np.shape(b["control_points"]) else float("inf") for a, b in pairs),
        default=0.0)
    out["within_tolerance"] = out["same_path"] and out["control_point_difference"] <= CONTROL_POINT_TOLERANCE
    for rs in runs.values():
        for r in rs:
            del r["control_points"]
    print("whole swings: " + "; ".join(f"{side} median {cpu:.3f} s" for side, cpu in out["median_cpu"].items())
          + f"; same results: {out['same_results']}; same degrees, iterations, successes: {out['same_path']}, "
          f"largest control-point difference {out['control_point_difference']:.2e}", flush=True)
    return out


def swings_markdown(result: dict) -> list[str]:
    sw = result["swings"]
    loads = [r["load"] for rs in sw["runs"].values() for r in rs]
    earlier = result.get("swings_from")
    run = f"run of {earlier['date']}, code {earlier['code']}, not repeated here" if earlier else "same run"
    lines = ["", f"### Step planning, whole swings: this tree against {sw.get('before', result['before'])} ({run})", "",
             f"{len(sw['swings'])} whole swings of the gap-crossing scenario (scarab2, every k-th of the sequence's "
             f"swings: {', '.join(map(str, sw['swings']))}), each planned by one long-lived process per tree "
             "(`plan_step`, `legplan step plan`'s planner call), item by item in alternation; CPU of the planning "
             f"call, one BLAS thread; load average {min(loads):.1f}–{max(loads):.1f}. Results bit for bit the same "
             f"(control points, degree, norm, status of every swing): {'yes' if sw['same_results'] else 'no'}"
             + ("" if sw["same_results"] or "same_path" not in sw else
                f"; the same degree, LM iterations per degree and success on every swing: "
                f"{'yes' if sw['same_path'] else 'NO'}, control points within "
                f"{sw['control_point_difference']:.1e} of each other (tolerance {CONTROL_POINT_TOLERANCE:g}: "
                f"{'kept' if sw['within_tolerance'] else 'MISSED'})") + ".", "",
             "| code | median item CPU [s] | mean [s] | successes | ratio to before |", "|---|---|---|---|---|"]
    before = sw["median_cpu"]["before"]
    for side, rs in sw["runs"].items():
        cpus = [r["cpu"] for r in rs]
        lines.append(f"| {side} | {statistics.median(cpus):.3f} | {statistics.mean(cpus):.3f} | "
                     f"{sum(r['success'] for r in rs)}/{len(rs)} | {statistics.median(cpus) / before:.2f} |")
    return lines


def jobs_markdown(result: dict) -> list[str]:
    jobs, earlier = result["jobs"], result.get("jobs_from")
    run = f"run of {earlier['date']}, code {earlier['code']}, not repeated here" if earlier else "same run"
    sides = {"this tree": jobs["variants"], **jobs.get("others", {})}
    lines = ["", f"### `legplan step plan --steps {jobs['steps']}`: --jobs 2 against --jobs 1 ({run})", "",
             "Gap-crossing scenario (scarab2, maps/gap_crossing.yaml, generated sequence), the whole command, "
             "--jobs 1 and --jobs 2 in alternation" + (", the trees' runs interleaved" if len(sides) > 1 else "")
             + ", median of "
             f"{len(next(iter(jobs['variants'].values()))['1']['runs'])} runs; load average during the runs in the "
             "last column (2 cores shared with other sessions: with both busy, no pool can approach 2×).", "",
             "| variant | code | median item [s] (--jobs 1, wall) | --jobs 1 wall [s] | --jobs 1 CPU [s] | --jobs 2 wall [s] | "
             "--jobs 2 CPU [s] | speed-up (wall) | load |",
             "|---|---|---|---|---|---|---|---|---|"]
    if "prestart_wall" in jobs:
        lines[5:5] = ["Before the items: `prestart` (called by `step plan --jobs 2` before it reads its inputs, step "
                      "plan's preload list), wall time until it returns to the command, median of "
                      f"{max(3, len(next(iter(jobs['variants'].values()))['1']['runs']))} runs: "
                      + "; ".join(f"{side} {value:.3f} s" for side, value in jobs["prestart_wall"].items()) + ".", ""]
    for variant in jobs["variants"]:
        for side, variants in sides.items():
            e = variants[variant]
            loads = [r["load"] for rs in (e["1"]["runs"], e["2"]["runs"]) for r in rs]
            lines.append(f"| {variant} | {side} | {statistics.median(e['item_seconds_jobs1_last_run']):.3f} | "
                         f"{e['1']['wall']:.2f} | {e['1']['cpu']:.2f} | {e['2']['wall']:.2f} | {e['2']['cpu']:.2f} | "
                         f"{e['speedup']:.2f}× | {min(loads):.1f}–{max(loads):.1f} |")
    return lines


def markdown(result: dict) -> str:
    sides = ["this tree", "this tree, empty store"] + (["before"] if result["before"] else [])
    head = (f"## cli — whole `legplan dyn plan` process CPU, bench/dyn.py's cases ({result['date']}, "
            f"{result['code']})\n")
    lines = [head,
             f"Machine: {result['machine']}, shared with other sessions: load average {result['load_start']:.1f} at the "
             f"start, {result['load_end']:.1f} at the end (CPU times on a loaded machine are noisy and "
             f"higher than idle). `legplan dyn plan MAP ... -o traj.h5 -q` (as the console script runs it, "
             f"`--costs none`, heuristic initializer, independent check on), one BLAS thread, process CPU "
             f"(user + system, `getrusage` of the child), median of {result['repeats']} runs"
             + (f"; 'before' is {result['before']} ({result['before_code']}), run in alternation with this tree "
                "in the same session" if result["before"] else "") + ". Start-up: a process importing exactly "
             "the modules the command imported and ending as it does; solve: CPU inside "
             "`solve_augmented_lagrangian`; rest: whole − start-up − solve (robot, map, problem, sampling, "
             f"check, work file, traj.h5). `legplan --version`: {result['version_cpu']:.3f} s"
             + (f" (before: {result['version_cpu_before']:.3f} s)" if result["before"] else "") + ". "
             + (f"Start-up floor, same run: the interpreter alone (`python -c pass`) "
                f"{result['floor_cpu']['interpreter']:.3f} s; the interpreter importing only the libraries `dyn plan` "
                f"cannot do without (`{FLOOR.splitlines()[0]}`, ending as the command does) "
                f"{result['floor_cpu']['libraries']:.3f} s. "
                if "floor_cpu" in result else "")
             + "Every side runs from compiled bytecode (a cache folder of the run, filled by an untimed first "
             "run; without it a source tree recompiles what it imports on every run). 'this tree' runs are "
             "repeated runs on the same map: the filtered terrain grids come from `legplan.cache`'s store "
             "(a folder of the run, filled by the first run); 'empty store' is the first run on a map (store "
             "emptied before each run, the filters computed and scipy.ndimage imported).",
             "",
             "TOWR column: the issue's figures, TOWR's whole process on this machine on another (idle) day. "
             "TOWR cannot be built and run here, so it was not measured in this run: it is context, and no "
             "ratio to it is taken.",
             "",
             "| case | code | whole [s] | start-up [s] | solve [s] | rest [s] | whole / before | exit | "
             "TOWR process, another day [s] |",
             "|---|---|---|---|---|---|---|---|---|"]
    for key, case in result["cases"].items():
        towr = TOWR_PROCESS_CPU.get(key)
        towr_text = f"{towr:.2f}" if towr is not None else TOWR_NOTES.get(key, "—")
        for side in sides:
            if side not in case:  # a result of a version without that row
                continue
            m = case[side]
            ratio = f"{m['whole'] / case['before']['whole']:.2f}" if "before" in case and side != "before" else "—"
            lines.append(f"| {case['label']} | {side} | {m['whole']:.3f} | {m['startup']:.3f} | {m['solve']:.3f} | "
                         f"{m['rest']:.3f} | {ratio} | {','.join(map(str, sorted(set(m['exit']))))} | {towr_text} |")
    lines.append("")
    lines.append("Exit 1 means the command ran and recorded a failed task (its reason is in traj.h5); the "
                 "CPU time is still the whole command's.")
    if result.get("jobs"):
        lines += jobs_markdown(result)
    if result.get("swings"):
        lines += swings_markdown(result)
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--cases", default="", help="comma-separated case keys of bench/dyn.py (default: all)")
    ap.add_argument("--before", type=Path, help="another legplan tree to run side by side (reference)")
    ap.add_argument("--no-append", action="store_true", help="do not update BENCHMARKS.md")
    ap.add_argument("--jobs-steps", default="60:80", help="pairs of the --jobs comparison (a:b)")
    ap.add_argument("--jobs-repeats", type=int, default=3)
    ap.add_argument("--step-map", type=Path, help="map.h5 of the gap-crossing scenario (built if not given)")
    ap.add_argument("--step-sequence", type=Path, help="its generated steps.h5 (generated if not given)")
    ap.add_argument("--skip-dyn", action="store_true", help="only the --jobs comparison")
    ap.add_argument("--skip-jobs", action="store_true", help="only the dyn plan cases")
    ap.add_argument("--before-code", default="", help="the revision of --before when it is an exported tree, not a checkout")
    ap.add_argument("--swings", type=int, default=12, help="whole swings planned side by side with --before (0: none)")
    args = ap.parse_args(argv)
    repeats = max(3, args.repeats)
    become_subreaper()  # the CPU of --jobs workers forked by a fork server counts (`child_run`)

    sys.path.insert(0, str(ROOT / "bench"))
    from dyn import CASES  # noqa: E402  (the cases, one list for both benchmarks)

    from legplan.terrain import build_map, save_map

    wanted = [] if args.skip_dyn else [c for c in CASES if not args.cases or c["key"] in args.cases.split(",")]
    trees = {"this tree": ROOT}
    if args.before is not None:
        trees["before"] = args.before.resolve()
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
              "before": str(args.before) if args.before else None, "repeats": repeats,
              "load_start": load_average(), "towr_process_cpu_issue_38": TOWR_PROCESS_CPU, "cases": {}}
    if args.before is not None:
        result["before_code"] = args.before_code or subprocess.run(
            ["git", "-C", str(args.before), "rev-parse", "--short", "HEAD"], capture_output=True, text=True).stdout.strip()
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        RUN_ENVIRONMENT.update(PYTHONPYCACHEPREFIX=str(work / "bytecode"), LEGPLAN_CACHE_DIR=str(work / "store"))
        version = {side: [] for side in trees}
        for _ in range(repeats):
            for side, tree in trees.items():
                cpu, _ = child_cpu([sys.executable, "-c", ENTRY, "--version"], environment(tree))
                version[side].append(cpu)
        result["version_cpu"] = statistics.median(version["this tree"])
        floor = {"interpreter": [], "libraries": []}  # the start-up floor (module docstring)
        for _ in range(repeats):
            for name, code in (("interpreter", "pass"), ("libraries", FLOOR)):
                floor[name].append(child_cpu([sys.executable, "-c", code], environment(ROOT))[0])
        result["floor_cpu"] = {name: statistics.median(v) for name, v in floor.items()}
        if args.before is not None:
            result["version_cpu_before"] = statistics.median(version["before"])
        maps = {}
        for case in wanted:
            if case["map"] not in maps:
                maps[case["map"]] = work / f"{case['map']}.h5"
                save_map(build_map(ROOT / "maps" / f"{case['map']}.yaml"), maps[case["map"]])
            cmd = command(case, maps[case["map"]], work / "traj.h5")
            lists = {side: work / f"modules-{case['key']}-{i}.json" for i, side in enumerate(trees)}
            for side, tree in trees.items():
                for _ in range(2):  # the list of the second run: the first one fills the caches
                    module_list(tree, cmd, lists[side])
            runs = {side: [] for side in trees}
            for i in range(repeats):
                order = list(trees) if i % 2 == 0 else list(trees)[::-1]
                for side in order:
                    runs[side].append(run_once(trees[side], cmd, work, lists[side]))
            empty = []  # this tree, the first run on the map: legplan.cache's store emptied before each
            lists["empty"] = work / f"modules-{case['key']}-empty.json"
            module_list(ROOT, cmd, lists["empty"], LEGPLAN_CACHE_DIR=str(work / "empty-store-list"))
            for i in range(repeats):
                store = work / f"empty-store-{case['key']}-{i}"
                empty.append(run_once(ROOT, cmd, work, lists["empty"], LEGPLAN_CACHE_DIR=str(store)))
                shutil.rmtree(store, ignore_errors=True)
            entry = {"label": case["label"], "command": ["legplan", *cmd[:2], f"{case['map']}.h5", *cmd[3:]],
                     "this tree, empty store": medians(empty)}
            for side in trees:
                entry[side] = medians(runs[side])
                if runs[side][-1]["exit"] not in (0, 1):
                    entry[side]["stderr"] = runs[side][-1]["stderr"]
            result["cases"][case["key"]] = entry
            print(f"{case['key']}: " + "; ".join(
                f"{side} whole {entry[side]['whole']:.3f} start-up {entry[side]['startup']:.3f} solve "
                f"{entry[side]['solve']:.3f} rest {entry[side]['rest']:.3f} exit {entry[side]['exit']}" for side in trees),
                flush=True)
        step_map, step_sequence = args.step_map, args.step_sequence
        if (not args.skip_jobs or (args.swings and args.before is not None)) and (step_map is None or step_sequence is None):
            from step_plan import scenario
            step_map, step_sequence = scenario(work, "scarab2", (-0.6, 0.0, 0.0), (0.6, 0.0, 0.0))
        if args.swings and args.before is not None:
            result["swings"] = swings_comparison(trees, step_map, step_sequence, args.swings)
            result["swings"]["before"] = str(args.before)
        else:  # the last run's whole-swing comparison stays in the section, marked as that run's
            previous = ROOT / "bench" / "results" / "cli.json"
            earlier = json.loads(previous.read_text()) if previous.exists() else {}
            if earlier.get("swings"):
                result["swings"] = {"before": earlier.get("before"), **earlier["swings"]}
                result["swings_from"] = earlier.get("swings_from") or {"date": earlier.get("date"),
                                                                       "code": earlier.get("code")}
        if not args.skip_jobs:
            result["jobs"] = jobs_comparison(work, args.jobs_steps, max(1, args.jobs_repeats), step_map,
                                             step_sequence, trees)
        else:  # the last run's --jobs comparison stays in the section, marked as that run's
            previous = ROOT / "bench" / "results" / "cli.json"
            earlier = json.loads(previous.read_text()) if previous.exists() else {}
            if earlier.get("jobs"):
                result["jobs"] = earlier["jobs"]
                result["jobs_from"] = earlier.get("jobs_from") or {"date": earlier.get("date"), "code": earlier.get("code")}
    result["load_end"] = load_average()
    write_result("cli", result)
    if not args.no_append:
        update_benchmarks("cli", markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
