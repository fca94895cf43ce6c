"""The shipped trained initializers (issue 39 item 1): how each training went and how its network does
on held-out tasks, read from the artefacts the `legplan learn` commands wrote.

    .venv/bin/python bench/shipped_initializers.py --cycle NAME=CYCLE_DIR ... \\
        --held-out LABEL=HELD_OUT.h5 ... [--section shipped_train] [--note TEXT]

`--cycle`: a `legplan learn cycle` output directory (its cycles.json and dataset_0.h5's command);
`--held-out`: a `legplan learn dataset --init INIT` run on tasks of another seed (its command, seed and
outcomes). Rows given the same held-out tasks (same space, n and seed) are directly comparable: the
side-by-side check of a retrained network against the one it would replace. Per held-out run: the
converged share, the converged tasks' median LM iterations, median cost and max/median cost (the
paper's Fig. 6 quantities), and their median solve seconds (wall inside a one-thread worker; the
machine's load at the time is what `--note` states, the seconds move with it, the rest does not).

Writes bench/results/<section>.json and its BENCHMARKS.md section.
"""

from __future__ import annotations

import argparse
import datetime
import json
import sys
from pathlib import Path

import numpy as np

from common import ROOT, code_version, load_average, machine, update_benchmarks, write_result


def pairs(values: list[str], option: str) -> list[tuple[str, Path]]:
    """LABEL=PATH arguments."""
    out = []
    for value in values:
        label, sep, path = value.partition("=")
        if not sep or not label or not path:
            sys.exit(f"{option} {value}: expected LABEL=PATH")
        out.append((label, Path(path)))
    return out


def provenance(path: Path) -> dict:
    sys.path.insert(0, str(ROOT))
    from legplan.artefacts import open_artefact, read_provenance

    with open_artefact(path) as f:
        return read_provenance(f)


def held_out_row(label: str, path: Path) -> dict:
    """The figures of one held-out dataset, with the command and seed that made it."""
    sys.path.insert(0, str(ROOT))
    from legplan.learn.dataset import read_dataset

    data = read_dataset(path)
    ok = np.asarray(data["success"], bool)
    cost = np.asarray(data["cost"], float)[ok]
    given = provenance(path)
    median = (lambda values: float(np.median(values)) if ok.any() else None)
    return {"label": label, "command": " ".join(given["command"][1:]), "seed": given["seed"],
            "space": data["space"]["name"], "tasks": int(ok.size), "converged": int(ok.sum()),
            "converged_percent": float(100.0 * ok.mean()),
            "median_iterations": median(np.asarray(data["iterations"], float)[ok]),
            "cost_median": median(cost), "max_over_median_cost": float(cost.max() / np.median(cost)) if ok.any() else None,
            "median_seconds": median(np.asarray(data["seconds"], float)[ok])}


def cycle_rows(name: str, directory: Path) -> dict:
    """cycles.json of a `learn cycle` directory and the command that wrote it."""
    rows = json.loads((directory / "cycles.json").read_text())["cycles"]
    return {"name": name, "command": " ".join(provenance(directory / "dataset_0.h5")["command"][1:]), "cycles": rows}


def number(value, digits: int = 2) -> str:
    return "–" if value is None else f"{value:.{digits}f}".rstrip("0").rstrip(".") if digits else f"{value:.0f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cycle", action="append", default=[], help="NAME=CYCLE_DIR (repeatable)")
    parser.add_argument("--held-out", action="append", default=[], help="LABEL=HELD_OUT.h5 (repeatable)")
    parser.add_argument("--section", default="shipped_train")
    parser.add_argument("--note", default="", help="what the section should say of the runs (load, code)")
    args = parser.parse_args()
    trainings = [cycle_rows(name, path) for name, path in pairs(args.cycle, "--cycle")]
    held = [held_out_row(label, path) for label, path in pairs(args.held_out, "--held-out")]
    result = {"date": datetime.datetime.now(datetime.timezone.utc).date().isoformat(), "machine": machine(),
              "code": code_version(), "load_average_now": load_average(), "note": args.note,
              "trainings": trainings, "held_out": held}
    write_result(args.section, result)

    training_md = "\n".join(
        f"| {t['name']} | {r['cycle']} | {r['init']} | {r['success_rate'] * 100:.0f} % | {number(r['median_iterations'], 1)} | "
        f"{number(r['cost_median'])} | {number(r['cost_max'])} |"
        for t in trainings for r in t["cycles"])
    commands = "\n".join(f"- {t['name']}: `legplan {t['command']}`" for t in trainings)
    held_md = "\n".join(
        f"| {h['label']} | {h['converged']}/{h['tasks']} ({h['converged_percent']:.0f} %) | "
        f"{number(h['median_iterations'], 1)} | {number(h['cost_median'])} | {number(h['max_over_median_cost'])} | "
        f"{number(h['median_seconds'])} |" for h in held)
    held_commands = "\n".join(f"- {h['label']}: `legplan {h['command']}`" for h in held)
    update_benchmarks(args.section, f"""
## {args.section} — shipped trained initializers (`bench/shipped_initializers.py`, {result['date']}, {machine()}, code {result['code']})

{args.note}

Trainings (Algorithm 1; per cycle the training tasks solved from that cycle's initializer, cycle 0 the
Heuristic with N_h = 100, later ones N_θ = 25; median iterations and costs of the converged tasks):

{commands}

| space | cycle | initializer | converged | median iterations | cost median | cost max |
|---|---|---|---|---|---|---|
{training_md}

Held-out tasks (another seed than the training's), each row's initializer and LM budget in its command:

{held_commands}

| network | converged | median iterations | cost median | max / median cost | median seconds |
|---|---|---|---|---|---|
{held_md}
""")


if __name__ == "__main__":
    main()
