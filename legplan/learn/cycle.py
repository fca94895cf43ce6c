"""`legplan learn cycle`: the artefacts and summary of Algorithm 1 (TRAININITIALIZER) of the TOWR-costs paper.

A cycle directory holds dataset_0.h5 (Y ← TOWR(A_h(X); N_h)), then for k = 1..K init_k.h5 (θ trained
on the filtered best outcome of every task in dataset_0 … dataset_{k-1}) and dataset_k.h5
(Y ← TOWR(A_θ(X); N_θ)), all on the same tasks X, and cycles.json: per cycle the initializer, success
rate, median iterations and time of the converged tasks, and their cost distribution (median, p90, max).

Deliberate change from Algorithm 1, which retrains on the last cycle's outcomes only: with the
N_θ = 25 budget, the learned solves stop at a higher cost than the Heuristic's 100 iterations
reach (measured on the 1000 single-pallet training tasks: the Heuristic's outcome was the best of
four for 720 tasks), and training on them carried that loss into the next network. Keeping each
task's best outcome makes the training targets improve monotonically over the cycles.
"""

from __future__ import annotations

import json
from pathlib import Path

from legplan.artefacts.publish import staged_output
from legplan.learn.dataset import read_dataset, summarize


def cycle_paths(directory: Path, cycles: int) -> list[Path]:
    """dataset_0.h5, init_1.h5, dataset_1.h5, ..., init_K.h5, dataset_K.h5."""
    paths = [directory / "dataset_0.h5"]
    for k in range(1, cycles + 1):
        paths += [directory / f"init_{k}.h5", directory / f"dataset_{k}.h5"]
    return paths


def cycle_row(k: int, dataset: Path) -> dict:
    """The summary of cycle k from its dataset."""
    data = read_dataset(dataset)
    summary = summarize(data["success"], data["iterations"], data["cost"], data["seconds"])
    return {"cycle": k, "init": "heuristic" if k == 0 else f"init_{k}.h5", "dataset": dataset.name,
            **{key: value[0] if isinstance(value, tuple) else value for key, value in summary.items()}}


def write_cycles(path: Path, rows: list[dict]) -> None:
    """cycles.json, written atomically (replaced each cycle)."""
    with staged_output(path, overwrite=True) as tmp:
        tmp.write_text(json.dumps({"cycles": rows}, indent=1) + "\n")
