"""Benchmark of how many-item commands start their `--jobs N` workers (issue 38): this tree against a
reference tree, side by side.

    nice -n 5 .venv/bin/python bench/fork_cmds.py --before /tmp/ref [--repeats 3] [--n 8] [--steps 60:80]

Two whole commands, each run as the `legplan` console script runs it (`cli.ENTRY`) in a fresh process
with one BLAS thread, the runs of both trees alternated (run i of both back to back, the order
swapped every run) so both see the same load; per command the median of --repeats runs of wall time
and process CPU (user + system of the command and every process it started, `cli.child_run`: this
process is a child subreaper, so a fork server's and its workers' CPU counts too):
  * `learn dataset tasks/flat_trot.yaml --n N --seed 0 --jobs 2`: the batch's workers, forked from the
    command with the context it built (`legplan.batch.fork_workers`), or, in a tree without that,
    forked by a fork server that imports the libraries and whose workers each build the context;
  * `step plan MAP STEPS --steps A:B` (`--jobs 1`) on bench/step_plan.py's gap-crossing scenario (scarab2,
    the pairs as generated): the command's CPU with the robot and map read once or twice.
The one-minute load average is recorded before every run. Writes bench/results/fork_cmds.json and
replaces the `fork_cmds` section of BENCHMARKS.md (not with --no-append).
"""

from __future__ import annotations

import argparse
import datetime
import statistics
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cli import ENTRY, RUN_ENVIRONMENT, child_run, environment  # noqa: E402
from common import ROOT, become_subreaper, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402


def side_by_side(trees: dict[str, Path], argv_of, repeats: int) -> dict:
    """`argv_of(tree, out)` of every tree, alternated, `repeats` times: per tree the runs and medians."""
    runs = {side: [] for side in trees}
    for i in range(repeats):
        for side in (list(trees) if i % 2 == 0 else list(trees)[::-1]):
            load = load_average()
            cpu, wall, done = child_run([sys.executable, "-c", ENTRY, *argv_of(trees[side], side)],
                                        environment(trees[side]))
            runs[side].append({"wall": wall, "cpu": cpu, "exit": done.returncode, "load": load,
                               "stderr": done.stderr.strip()[-300:]})
            print(f"{argv_of(trees[side], side)[:2]} {side}: wall {wall:.2f} s, cpu {cpu:.2f} s, exit "
                  f"{done.returncode}, load {load:.1f}", flush=True)
    return {side: {"wall": statistics.median(r["wall"] for r in rs), "cpu": statistics.median(r["cpu"] for r in rs),
                   "runs": rs} for side, rs in runs.items()}


def markdown(result: dict) -> str:
    loads = [r["load"] for case in result["cases"].values() for side in case.values() for r in side["runs"]]
    lines = [f"## fork_cmds — `--jobs N` workers forked from the command, and `step plan` reading its inputs once "
             f"(`bench/fork_cmds.py`, {result['date']}, {result['machine']}, {result['code']}, reference "
             f"{result['reference']}; load {min(loads):.1f}–{max(loads):.1f}: shared machine, timings noisy)",
             "", f"Median of {result['repeats']} runs of each whole command, the trees alternated.", "",
             "| command | tree | wall s | CPU s | wall ratio | CPU ratio | exits |", "|---|---|---|---|---|---|---|"]
    for name, case in result["cases"].items():
        before = case["reference"]
        for side, entry in case.items():
            lines.append(f"| `{name}` | {side} | {entry['wall']:.2f} | {entry['cpu']:.2f} | "
                         f"{entry['wall'] / before['wall']:.3f} | {entry['cpu'] / before['cpu']:.3f} | "
                         f"{','.join(str(r['exit']) for r in entry['runs'])} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--before", type=Path, required=True, help="The reference legplan tree.")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--n", type=int, default=8, help="Tasks of the learn dataset run.")
    parser.add_argument("--steps", default="60:80", help="The step plan run's --steps.")
    parser.add_argument("--no-append", action="store_true")
    args = parser.parse_args(argv)
    from step_plan import scenario

    become_subreaper()
    trees = {"this tree": ROOT, "reference": args.before.resolve()}
    with tempfile.TemporaryDirectory(prefix="fork_cmds-") as folder:
        work = Path(folder)
        RUN_ENVIRONMENT.update(PYTHONPYCACHEPREFIX=str(work / "bytecode"), LEGPLAN_CACHE_DIR=str(work / "store"))
        map_path, steps_path = scenario(work, "scarab2", (-0.6, 0.0, 0.0), (0.6, 0.0, 0.0))
        space = str(ROOT / "tasks" / "flat_trot.yaml")
        dataset = f"learn dataset flat_trot --n {args.n} --jobs 2"
        step = f"step plan --steps {args.steps}"
        commands = {
            dataset: lambda tree, side: ["learn", "dataset", space, "--n", str(args.n), "--seed", "0", "--jobs", "2",
                                         "-o", str(work / f"dataset-{side[0]}.h5"), "--overwrite", "-q"],
            step: lambda tree, side: ["step", "plan", str(map_path), str(steps_path), "--steps", args.steps,
                                      "-o", str(work / f"motion-{side[0]}.h5"), "--overwrite", "-q"]}
        result = {"date": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d %H:%M UTC"),
                  "machine": machine(), "code": code_version(), "reference": str(args.before), "repeats": args.repeats,
                  "cases": {}}
        for name, argv_of in commands.items():
            side_by_side(trees, argv_of, 1)  # untimed: fills both trees' bytecode caches and the terrain store
            result["cases"][name] = side_by_side(trees, argv_of, args.repeats)
    write_result("fork_cmds", result)
    if not args.no_append:
        update_benchmarks("fork_cmds", markdown(result))
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
