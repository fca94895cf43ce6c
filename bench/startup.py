"""Instruction counts of `legplan dyn plan`'s start-up and whole command, this tree against a reference
tree (issue 38: start-up and everything outside the solve), under valgrind's callgrind.

    nice -n 5 .venv/bin/python bench/startup.py --before /tmp/ref --before-code REV [--cli-result FILE]

CPU seconds on a machine shared with other sessions swing with the load; instruction counts do not
(they repeat to a fraction of a percent), so this is the side-by-side figure of the start-up work. For
each tree (run in turn, one BLAS thread, each with its own bytecode cache, filled by an untimed first
run, and its own `legplan.cache` store, filled likewise) on bench/dyn.py's flat trot (`legplan dyn
plan MAP --gait trot --strides 4 --duration 2.4 ...`, `--costs none`, the independent check on):
  * start-up: a process that imports exactly the modules that tree's command imported, in the same
    order, and ends as the console script does (bench/cli.py's `STARTUP`, with the list of its
    `MODULES`);
  * whole: the command as the console script runs it (bench/cli.py's `ENTRY`);
  * `legplan --version`;
and, once, the floor: the interpreter importing only the libraries `dyn plan` cannot do without
(bench/cli.py's `FLOOR`). Also recorded: how many modules each tree's command imports, and which of
the modules this change keeps off the command's path (`WATCHED`) each imports. Instruction counts of
the whole command include the solve, which is not this benchmark's subject; the split of CPU time
into start-up, solve and the rest is bench/cli.py's (`--cli-result`: that run's JSON, whose flat-trot
rows are quoted in the section).

Writes bench/results/startup.json and replaces the `startup` section of BENCHMARKS.md (not with
--no-append). With --measured JSON nothing is measured: that earlier run's counts get the
--cli-result rows, and the section is written from them.
"""

from __future__ import annotations

import argparse
import datetime
import json
import subprocess
import sys
import tempfile
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from cli import ENTRY, FLOOR, MODULES, RUN_ENVIRONMENT, STARTUP, command, environment  # noqa: E402
from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result  # noqa: E402

# modules that `dyn plan` on a known map no longer imports (tests/cli/test_startup.py asserts it)
WATCHED = ("numpy.ma", "xml.etree.ElementTree", "pyexpat", "csv", "tempfile", "legplan.robots.urdf")


def instructions(argv: list[str], env: dict, work: Path, name: str) -> int:
    """Instructions executed by `argv` (callgrind's total, the process's children not followed)."""
    out = work / f"{name}.callgrind"
    subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}", *argv], env=env,
                   cwd=env["PYTHONPATH"], capture_output=True, check=False)
    for line in out.read_text(errors="replace").splitlines():
        if line.startswith(("summary:", "totals:")):
            return int(line.split()[1])
    raise RuntimeError(f"{name}: callgrind wrote no total")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--before", type=Path, required=True, help="the reference legplan tree")
    ap.add_argument("--before-code", default="", help="the revision of --before")
    ap.add_argument("--cli-result", type=Path, help="bench/cli.py's JSON of a side-by-side run with the same --before")
    ap.add_argument("--no-append", action="store_true", help="do not update BENCHMARKS.md")
    ap.add_argument("--measured", type=Path, help="no measuring: this run's earlier JSON (with its --before), "
                    "to add --cli-result and write the section")
    args = ap.parse_args(argv)
    result = json.loads(args.measured.read_text()) if args.measured is not None else measure(args)
    if args.cli_result is not None:
        cli = json.loads(args.cli_result.read_text())
        path = args.cli_result.resolve()
        result["cli"] = {"file": str(path.relative_to(ROOT) if path.is_relative_to(ROOT) else path),
                         "date": cli["date"], "code": cli["code"], "load_start": cli["load_start"],
                         "load_end": cli["load_end"], "repeats": cli["repeats"], "version_cpu": cli["version_cpu"],
                         "version_cpu_before": cli.get("version_cpu_before"), "floor_cpu": cli["floor_cpu"],
                         "cases": cli["cases"]}
    write_result("startup", result)
    if not args.no_append:
        update_benchmarks("startup", markdown(result))
    return 0


def measure(args) -> dict:
    """Every count of the module docstring, both trees."""
    sys.path.insert(0, str(ROOT / "bench"))
    from dyn import CASES

    from legplan.terrain import build_map, save_map

    case = next(c for c in CASES if c["key"] == "flat_trot")
    trees = {"this tree": ROOT, "before": args.before.resolve()}
    result = {"date": datetime.date.today().isoformat(), "machine": machine(), "code": code_version(),
              "before": str(args.before), "before_code": args.before_code, "case": case["key"],
              "load_start": load_average(), "trees": {}}
    with tempfile.TemporaryDirectory() as tmp:
        work = Path(tmp)
        map_path = work / "flat.h5"
        save_map(build_map(ROOT / "maps" / "flat.yaml"), map_path)
        cmd = command(case, map_path, work / "traj.h5")
        for i, (side, tree) in enumerate(trees.items()):
            RUN_ENVIRONMENT.update(PYTHONPYCACHEPREFIX=str(work / f"bytecode-{i}"), LEGPLAN_CACHE_DIR=str(work / f"store-{i}"))
            env = environment(tree)
            modules = work / f"modules-{i}.json"
            for _ in range(2):  # the list of the second run: the first one fills the caches
                subprocess.run([sys.executable, "-c", MODULES, *cmd], env={**env, "LEGPLAN_BENCH_MODULES": str(modules)},
                               cwd=tree, capture_output=True, check=False)
            subprocess.run([sys.executable, "-c", STARTUP, str(modules)], env=env, cwd=tree, capture_output=True, check=False)
            names = json.loads(modules.read_text())
            entry = {"modules": len(names), "watched_imported": [m for m in WATCHED if m in names],
                     "startup": instructions([sys.executable, "-c", STARTUP, str(modules)], env, work, f"startup-{i}"),
                     "whole": instructions([sys.executable, "-c", ENTRY, *cmd], env, work, f"whole-{i}"),
                     "version": instructions([sys.executable, "-c", ENTRY, "--version"], env, work, f"version-{i}")}
            if side == "this tree":
                entry["floor"] = instructions([sys.executable, "-c", FLOOR], env, work, "floor")
            result["trees"][side] = entry
            print(f"{side}: {entry}", flush=True)
    result["load_end"] = load_average()
    return result


def markdown(result: dict) -> str:
    ours, before = result["trees"]["this tree"], result["trees"]["before"]
    lines = [f"## startup — `dyn plan` start-up and the rest, this tree against {result['before_code'] or result['before']} "
             f"({result['date']}, {result['code']})", "",
             f"Machine: {result['machine']}, shared with other sessions (load average {result['load_start']:.1f} at the "
             f"start, {result['load_end']:.1f} at the end). bench/startup.py: valgrind callgrind instruction counts "
             "(repeatable under load) of bench/dyn.py's flat trot, each tree with its own filled bytecode cache and "
             "terrain store; start-up = a process importing exactly the modules that tree's command imports and ending "
             "as the console script does; whole = the command (solve included).", "",
             "| | this tree [10⁶ instr.] | before [10⁶ instr.] | ratio |", "|---|---|---|---|"]
    for key, label in (("startup", "start-up"), ("whole", "whole command"), ("version", "`legplan --version`")):
        lines.append(f"| {label} | {ours[key] / 1e6:.0f} | {before[key] / 1e6:.0f} | {ours[key] / before[key]:.3f} |")
    lines += [f"| floor (interpreter + the libraries `dyn plan` needs, bench/cli.py's `FLOOR`) | {ours['floor'] / 1e6:.0f} | | |",
              "", f"Modules imported by the command: {ours['modules']} against {before['modules']}; of "
              f"{', '.join(WATCHED)}, this tree imports {', '.join(ours['watched_imported']) or 'none'}, before "
              f"{', '.join(before['watched_imported']) or 'none'}. Start-up above the floor: "
              f"{(ours['startup'] - ours['floor']) / 1e6:.0f} against {(before['startup'] - ours['floor']) / 1e6:.0f} "
              "million instructions."]
    cli = result.get("cli")
    if cli:
        lines += ["", f"Process CPU, bench/cli.py run side by side with the same reference ({cli['file']}, {cli['date']}, "
                  f"code {cli['code']}; load average {cli['load_start']:.1f} → {cli['load_end']:.1f}; medians of "
                  f"{cli['repeats']} runs, the trees alternated):", "",
                  "| case | code | whole [s] | start-up [s] | solve [s] | rest [s] | whole / before |", "|---|---|---|---|---|---|---|"]
        rows = [(key, side, entry[side], entry["before"]["whole"]) for key, entry in cli["cases"].items()
                for side in ("this tree", "before")]
        lines.extend(f"| {key} | {side} | {e['whole']:.3f} | {e['startup']:.3f} | {e['solve']:.3f} | {e['rest']:.3f} | "
                     f"{e['whole'] / reference:.2f} |" for key, side, e, reference in rows)
        floor = cli["floor_cpu"]
        lines.append("")
        lines.append(f"Same run: `legplan --version` {cli['version_cpu']:.3f} s (before {cli['version_cpu_before']:.3f} s); "
                     f"the interpreter alone {floor['interpreter']:.3f} s, the floor {floor['libraries']:.3f} s.")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    sys.exit(main())
