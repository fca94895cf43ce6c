"""Algorithm 1 (TRAININITIALIZER) of the TOWR-costs paper as a library function, `run_cycle`, which
`legplan learn cycle` calls:

    rows = run_cycle("tasks/single_pallet_walk.yaml", "cycle/", cycles=3, count=1000, seed=0)

A cycle directory holds dataset_0.h5 (Y ← TOWR(A_h(X); N_h)), then for k = 1..K init_k.h5 (θ trained
on the filtered best outcome of every task in dataset_0 … dataset_{k-1}) and dataset_k.h5
(Y ← TOWR(A_θ(X); N_θ)), all on the same tasks X, and cycles.json: per cycle the initializer, success
rate, median iterations and time of the converged tasks, and their cost distribution (median, p90, max).

Deliberate change from Algorithm 1, which retrains on the last cycle's outcomes only: with the
N_θ = 25 budget, the learned solves can stop at a higher cost than the Heuristic's N_h = 100
iterations reach, and training on them would carry that loss into the next network. Keeping each
task's best converged outcome (`legplan.learn.dataset.best_outcomes`) makes the training targets
improve monotonically over the cycles.
"""

from __future__ import annotations

import json
import logging
import os
from collections.abc import Callable
from pathlib import Path

from legplan.artefacts.publish import staged_output
from legplan.errors import LegplanError
from legplan.learn.dataset import make_dataset, read_dataset, run_in_process, summarize

log = logging.getLogger(__name__)


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


def run_cycle(space_path, output, *, count: int, cycles: int = 3, seed: int = 0, heuristic_iterations: int = 100,
              learned_iterations: int = 25, g_max: float | str = "auto", hidden: tuple[int, ...] = (256, 256),
              hidden_later: tuple[int, ...] = (256, 256, 256), weights_path=None, optimize_phases: bool = False,
              fit_params=None, overwrite: bool = False, resume: bool = False, run=run_in_process,
              report: Callable[[str], None] = log.info) -> list[dict]:
    """Algorithm 1 on the task space `space_path`, its artefacts in the directory `output`
    (`cycle_paths`): Y ← solve(A_h(X); N_h) on `count` tasks X drawn with `seed`, then `cycles` times
    filter (eq. (4)) and train (eq. (3)) A_θ on each task's best converged outcome so far and
    Y ← solve(A_θ(X); N_θ) on the same X. The first network has `hidden` layers, the later ones
    `hidden_later` (more tasks pass the filter); `fit_params` (`legplan.learn.network.FitParams`, None:
    its defaults) how every one is fitted. Returns the rows of cycles.json (`cycle_row`).

    Existing artefacts are refused (one line) unless `overwrite`, or reused with `resume` (an
    interrupted dataset continues from its work file). `run` runs each dataset's batch
    (`make_dataset`); `report` receives one line per artefact written and per cycle."""
    from legplan.artefacts import check_output
    from legplan.learn.space import read_space
    from legplan.learn.train import train_initializer
    from legplan.learn.dataset import check_space_sizes
    from legplan.learn.network import FitParams, filter_rule, read_weights

    space = read_space(space_path)
    check_space_sizes(space, space_path, "costs", optimize_phases)
    output = Path(output)
    paths = cycle_paths(output, cycles)
    if not resume:
        for path in paths:
            check_output(path, overwrite)
    if weights_path is not None and not os.path.isfile(weights_path):
        raise LegplanError(f"--weights: '{weights_path}' is not a file")
    read_weights(weights_path)  # a bad weights file fails now, not after the first dataset
    output.mkdir(parents=True, exist_ok=True)

    def done(path) -> bool:  # reused with resume
        return resume and Path(path).exists()

    rows = []
    for k in range(cycles + 1):
        dataset = paths[2 * k]
        if k > 0:
            init = paths[2 * k - 1]
            if not done(init):
                trained = train_initializer(paths[0:2 * k - 1:2], init, g_max=g_max,
                                            hidden=hidden if k == 1 else hidden_later, weights_path=weights_path,
                                            seed=seed, overwrite=overwrite, fit_params=fit_params or FitParams())
                report(f"wrote {init}: {trained['good']}/{trained['tasks']} tasks with "
                       f"{filter_rule(trained['g_max'], bool(trained['g_max_conditional']))}, "
                       f"validation loss {trained['validation_loss']:.3g}")
        if not done(dataset):
            records = make_dataset(space, space_path, count, seed, paths[2 * k - 1] if k else "heuristic",
                                   learned_iterations if k else heuristic_iterations, dataset,
                                   optimize_phases=optimize_phases, overwrite=overwrite, run=run)
            report(f"wrote {dataset}: {sum(bool(r['success']) for r in records)}/{len(records)} tasks converged")
        rows.append(cycle_row(k, dataset))
        report("cycle {cycle}: {init}, success {success_rate:.0%}, median iterations {median_iterations:g}, "
               "cost median {cost_median:.4g} / p90 {cost_p90:.4g} / max {cost_max:.4g}".format(**rows[-1]))
    write_cycles(output / "cycles.json", rows)
    report(f"wrote {output / 'cycles.json'}")
    return rows
